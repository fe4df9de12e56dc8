"""A second co-simulation master: the controller and plant FMUs in closed loop inside an FMU
container built by fmu-manipulation-toolbox (`fmucontainer`'s Python API), simulated by FMPy.
Prints JSON.

usage: container_closed_loop.py CONTROLLER.fmu PLANT.fmu WORKDIR DURATION PERIOD

The container steps its FMUs sequentially (the controller first, then the plant, each reading
what the one before it has just output) every PERIOD s: the master algorithm of
`zmp_models::closed_loop::run`. The ZMP reference is the container's input, 0.12 m at t = 0
and 0.17 m from the first controller period on, as in the seed's experiment.
"""
import contextlib
import json
import shutil
import sys
from pathlib import Path

import numpy as np
from fmpy import simulate_fmu
from fmu_manipulation_toolbox.container import FMUContainer

controller, plant, work = Path(sys.argv[1]), Path(sys.argv[2]), Path(sys.argv[3])
duration, period = float(sys.argv[4]), float(sys.argv[5])
work.mkdir(parents=True, exist_ok=True)
for f in (controller, plant):
    shutil.copy(f, work / f.name)
c, p = controller.name, plant.name

# The toolbox logs to stdout: keep stdout for the JSON.
with contextlib.redirect_stdout(sys.stderr):
    container = FMUContainer("zmp_loop", work, fmi_version=2)
    container.get_fmu(c)
    container.get_fmu(p)
    for axis in ("x", "y"):
        container.add_input(f"zmp_ref_{axis}", c, f"zmp_ref_{axis}")
        container.add_link(c, f"{axis}_cr", p, f"{axis}_cr")
        container.add_link(p, f"zmp_{axis}", c, f"zmp_{axis}")
        for fmu, port in ((p, f"zmp_{axis}"), (p, f"{axis}_c"), (c, f"{axis}_cr"),
                          (c, f"theta_{axis}")):
            container.add_output(fmu, port, f"{Path(fmu).stem.removeprefix('zmp_')}_{port}")
    # Only the routes above: the two FMUs share port names, which must not link by name.
    container.add_implicit_rule(auto_input=False, auto_output=False, auto_link=False)
    container.make_fmu("zmp_loop.fmu", step_size=period, sequential=True)

    signal = np.array([(0.0, 0.12, 0.0), (period, 0.17, 0.0), (duration, 0.17, 0.0)],
                      dtype=[('time', np.double), ('zmp_ref_x', np.double),
                             ('zmp_ref_y', np.double)])
    outputs = [f"{Path(fmu).stem.removeprefix('zmp_')}_{port}" for axis in ("x", "y")
               for fmu, port in ((p, f"zmp_{axis}"), (p, f"{axis}_c"), (c, f"{axis}_cr"),
                                 (c, f"theta_{axis}"))]
    res = simulate_fmu(str(work / "zmp_loop.fmu"), start_time=0.0, stop_time=duration,
                       output_interval=period, input=signal, output=outputs)

print(json.dumps({"container": str(work / "zmp_loop.fmu"), "time": res["time"].tolist(),
                  **{name: res[name].tolist() for name in outputs}}))
