"""Simulates the plant FMU with FMPy's simulate_fmu and an input signal; prints JSON.

usage: simulate_plant.py PLANT.fmu OUTPUT_INTERVAL STOP_TIME START_VALUES_JSON
"""
import json
import sys

import numpy as np
from fmpy import read_model_description, simulate_fmu

fmu, dt, stop = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
start_values = json.loads(sys.argv[4])

md = read_model_description(fmu)
start = {v.name: float(v.start) for v in md.modelVariables if v.start is not None}
x0, y0 = start['x_cr'], start['y_cr']

# The input samples sit exactly on the communication points, so FMPy applies them unchanged.
n = int(round(stop / dt))
t = np.arange(n + 1) * dt
x = x0 + 0.02 * np.sin(2 * np.pi * 0.7 * t) + 0.01 * np.minimum(t, 0.5)
y = y0 + 0.01 * (1 - np.cos(2 * np.pi * 1.3 * t))
signal = np.array(list(zip(t, x, y)),
                  dtype=[('time', np.double), ('x_cr', np.double), ('y_cr', np.double)])

outputs = ['zmp_x', 'zmp_y', 'x_c', 'y_c']
res = simulate_fmu(fmu, start_time=0.0, stop_time=stop, output_interval=dt, input=signal,
                   start_values=start_values, output=outputs)

print(json.dumps({
    't_in': t.tolist(), 'x_cr': x.tolist(), 'y_cr': y.tolist(),
    'time': res['time'].tolist(),
    **{name: res[name].tolist() for name in outputs},
}))
