"""Drives the plant FMU's x_cr with a sampled sine through FMPy's simulate_fmu; prints JSON.

usage: simulate_sine.py PLANT.fmu OUTPUT_INTERVAL STOP_TIME OMEGA SAMPLE_PERIOD DERIVATIVES

The sine (5 mm around the FMU's start value of x_cr) is tabulated every SAMPLE_PERIOD; FMPy
sets the table's value at each communication point, and with DERIVATIVES = 1 also the slope
of the table's segment (set_input_derivatives=True: fmi2SetRealInputDerivatives).
"""
import contextlib
import json
import sys

import fmpy.simulation
import numpy as np
from fmpy import read_model_description, simulate_fmu

# FMPy 0.3.32 allocates nine input-derivative slots whatever the number of continuous inputs,
# so set_input_derivatives=True fails ("Can only assign sequence of same size") unless an FMU
# has exactly nine: size them to the inputs.
_input_init = fmpy.simulation.Input.__init__


def _input_init_sized(self, *args, **kwargs):
    _input_init(self, *args, **kwargs)
    self.continuous = [c._replace(derivatives=(c.derivatives._type_ * len(c.vrs))())
                       for c in getattr(self, 'continuous', [])]


fmpy.simulation.Input.__init__ = _input_init_sized

fmu, dt, stop, omega, ts = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), \
    float(sys.argv[4]), float(sys.argv[5])
derivatives = sys.argv[6] == '1'

md = read_model_description(fmu)
start = {v.name: float(v.start) for v in md.modelVariables if v.start is not None}
x0, y0 = start['x_cr'], start['y_cr']

n = int(round(stop / ts))
t = np.arange(n + 1) * ts
x = x0 + 0.005 * np.sin(omega * t)
y = np.full_like(t, y0)
signal = np.array(list(zip(t, x, y)),
                  dtype=[('time', np.double), ('x_cr', np.double), ('y_cr', np.double)])

outputs = ['zmp_x', 'zmp_y']
# FMPy's own messages go to stderr: stdout carries the JSON only.
with contextlib.redirect_stdout(sys.stderr):
    res = simulate_fmu(fmu, start_time=0.0, stop_time=stop, output_interval=dt, input=signal,
                       output=outputs, set_input_derivatives=derivatives)

print(json.dumps({
    'x0': x0, 'y0': y0, 't_in': t.tolist(), 'x_cr': x.tolist(),
    'time': res['time'].tolist(),
    **{name: res[name].tolist() for name in outputs},
}))
