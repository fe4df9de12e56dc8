"""Peer of the twin's step benchmark (validation/twin/benches/step.rs): the same model
(models/mjcf/silo2.xml) stepped by MuJoCo's own Python bindings (mujoco==3.17.0, the same
library version the twin links).

Usage: python mujoco_step.py MODEL.xml STEPS

Work per step, as in the Rust bench: set the two trunk servo references (a 6 rad/s sine of
0.07 rad on the lateral tilt) and call mj_step, from the standing keyframe. Two loops:
- `python_loop`: one Python iteration per step (what a Python controller does);
- `nstep`: the references set once per 10 steps and `mj_step(m, d, nstep=10)` (the C loop does
  the stepping; the fastest the bindings allow with a 100 Hz controller).
Prints JSON: steps, wall seconds and CPU seconds of this thread (`time.thread_time`) of each
loop (each after 1000 warm-up steps).
"""

import json
import math
import sys
import time

import mujoco


def main():
    path, steps = sys.argv[1], int(sys.argv[2])
    m = mujoco.MjModel.from_xml_path(path)
    lat = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, "trunk_lateral")
    key = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, "stand")
    dt = m.opt.timestep
    out = {"mujoco": mujoco.__version__, "steps": steps}

    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, key)
    for k in range(1000):
        d.ctrl[lat] = 0.07 * math.sin(6.0 * k * dt)
        mujoco.mj_step(m, d)
    t0, c0 = time.perf_counter(), time.thread_time()
    for k in range(steps):
        d.ctrl[lat] = 0.07 * math.sin(6.0 * k * dt)
        mujoco.mj_step(m, d)
    out["python_loop_wall_s"] = time.perf_counter() - t0
    out["python_loop_cpu_s"] = time.thread_time() - c0

    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, key)
    mujoco.mj_step(m, d, nstep=1000)
    t0, c0 = time.perf_counter(), time.thread_time()
    for k in range(0, steps, 10):
        d.ctrl[lat] = 0.07 * math.sin(6.0 * k * dt)
        mujoco.mj_step(m, d, nstep=10)
    out["nstep_wall_s"] = time.perf_counter() - t0
    out["nstep_cpu_s"] = time.thread_time() - c0
    print(json.dumps(out))


if __name__ == "__main__":
    main()
