"""Per-step cost of the plant FMU against the trivial pass-through FMU through FMPy, in the same
run, interleaved: both have 2 inputs and 4 outputs, so the difference is the plant's physics and
the FMU's own overhead.

usage: overhead.py PLANT.fmu PASSTHROUGH.fmu [STEPS] [ROUNDS]

Two loops, each timed ROUNDS times per FMU (alternating), minimum kept:
- simulate_fmu: FMPy's own co-simulation loop (input signal, recorder), output_interval 1 ms;
- slave: a hand-written FMU2Slave loop (setReal 2 inputs, doStep 1 ms, getReal 4 outputs).
Prints JSON with microseconds per step and the relative overhead of the plant.
"""
import json
import shutil
import sys
import time

import numpy as np
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi2 import FMU2Slave

plant_fmu, pass_fmu = sys.argv[1], sys.argv[2]
steps = int(sys.argv[3]) if len(sys.argv) > 3 else 20000
rounds = int(sys.argv[4]) if len(sys.argv) > 4 else 5
dt = 1e-3


def prepare(fmu, inputs, outputs):
    md = read_model_description(fmu)
    d = extract(fmu)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    start = {v.name: float(v.start) for v in md.modelVariables if v.start is not None}
    t = np.arange(steps + 1) * dt
    u0 = [start[n] for n in inputs]
    sig = np.array(list(zip(t, u0[0] + 0.01 * np.sin(5 * t), u0[1] + 0.01 * np.cos(3 * t))),
                   dtype=[('time', np.double), (inputs[0], np.double), (inputs[1], np.double)])
    return dict(md=md, dir=d, vr_in=[vr[n] for n in inputs], vr_out=[vr[n] for n in outputs],
                signal=sig, outputs=outputs)


def run_simulate(p):
    t0 = time.perf_counter()
    simulate_fmu(p['dir'], model_description=p['md'], start_time=0.0, stop_time=steps * dt,
                 output_interval=dt, input=p['signal'], output=p['outputs'], validate=False)
    return (time.perf_counter() - t0) / steps * 1e6


def run_slave(p):
    md = p['md']
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=p['dir'],
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName='bench')
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    sig = p['signal']
    names = sig.dtype.names[1:]
    a, b = sig[names[0]], sig[names[1]]
    vin, vout = p['vr_in'], p['vr_out']
    t0 = time.perf_counter()
    for k in range(steps):
        fmu.setReal(vin, [a[k], b[k]])
        fmu.doStep(currentCommunicationPoint=k * dt, communicationStepSize=dt)
        fmu.getReal(vout)
    el = time.perf_counter() - t0
    fmu.terminate()
    fmu.freeInstance()
    return el / steps * 1e6


plant = prepare(plant_fmu, ['x_cr', 'y_cr'], ['zmp_x', 'zmp_y', 'x_c', 'y_c'])
trivial = prepare(pass_fmu, ['u1', 'u2'], ['y1', 'y2', 'y3', 'y4'])
result = {'steps': steps, 'rounds': rounds}
for name, fn in [('simulate_fmu', run_simulate), ('slave', run_slave)]:
    fn(plant), fn(trivial)  # warm-up
    tp, tt = [], []
    for _ in range(rounds):
        tp.append(fn(plant))
        tt.append(fn(trivial))
    result[name] = {'plant_us_per_step': min(tp), 'trivial_us_per_step': min(tt),
                    'overhead': min(tp) / min(tt) - 1.0}
for p in (plant, trivial):
    shutil.rmtree(p['dir'], ignore_errors=True)
print(json.dumps(result))
