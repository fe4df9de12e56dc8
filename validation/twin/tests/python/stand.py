"""Loads MJCF files with MuJoCo's own Python bindings and lets each robot stand for a while from
a keyframe (or, with start "qpos0", from the pose the file loads in), recording what a fall, a
jump or a slide would change. Independent of the Rust twin code: only `mujoco` and `numpy`.

usage: stand.py SECONDS FILE:START [FILE:START ...]   (START: a keyframe's name or qpos0)
prints one JSON object per line: file, start, and the measures below.
"""

import json
import sys

import mujoco
import numpy as np


def stand(path, start, seconds):
    m = mujoco.MjModel.from_xml_path(path)
    d = mujoco.MjData(m)
    if start == "qpos0":
        mujoco.mj_resetData(m, d)
    else:
        mujoco.mj_resetDataKeyframe(m, d, m.key(start).id)
    mujoco.mj_forward(m, d)
    # The floating base: the body of the free joint.
    free = [j for j in range(m.njnt) if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE]
    base = m.jnt_bodyid[free[0]]
    adr = m.jnt_qposadr[free[0]]

    def deepest():
        return min([0.0] + [d.contact[i].dist for i in range(d.ncon)])

    z0 = d.qpos[adr + 2]
    com0 = d.subtree_com[base].copy()
    out = {
        "file": path,
        "start": start,
        "initial_contacts": int(d.ncon),
        "initial_penetration_m": -deepest(),
        "base_height_m": float(z0),
        "max_base_height_change_m": 0.0,
        "max_tilt_deg": 0.0,
        "max_penetration_m": 0.0,
        "max_com_drift_m": 0.0,
    }
    steps = int(round(seconds / m.opt.timestep))
    for _ in range(steps):
        mujoco.mj_step(m, d)
        out["max_base_height_change_m"] = max(
            out["max_base_height_change_m"], abs(d.qpos[adr + 2] - z0))
        # The base's z axis against the vertical.
        tilt = np.degrees(np.arccos(np.clip(d.xmat[base][8], -1.0, 1.0)))
        out["max_tilt_deg"] = max(out["max_tilt_deg"], float(tilt))
        out["max_penetration_m"] = max(out["max_penetration_m"], -deepest())
        drift = np.hypot(*(d.subtree_com[base][:2] - com0[:2]))
        out["max_com_drift_m"] = max(out["max_com_drift_m"], float(drift))
    out["final_contacts"] = int(d.ncon)
    out["final_max_speed"] = float(np.abs(d.qvel).max())
    out["simulated_s"] = float(d.time)
    return out


def main():
    seconds = float(sys.argv[1])
    for arg in sys.argv[2:]:
        path, start = arg.rsplit(":", 1)
        print(json.dumps(stand(path, start, seconds)))


if __name__ == "__main__":
    main()
