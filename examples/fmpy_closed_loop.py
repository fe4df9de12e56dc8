"""The ZMP plant and the cascade controller FMUs in closed loop with FMPy: the first seed's
step-and-disturbance experiment (section 6.6). The ZMP reference steps 0.12 -> 0.17 m at t = 0;
at t = 80 s a 4 kg load is placed 0.30 m out on the lateral axis, which moves the measured ZMP.

Build the FMUs first (`cargo xtask fmu --model models/params/silo2-paper.toml --out target/fmu`),
then, with the venv of `cargo xtask setup`:

    ~/.cache/zmp-toolkit/venv/bin/python examples/fmpy_closed_loop.py --out closed_loop.png

Works with the FMI 2.0 FMUs (FMPy's FMU2Slave, the default) and the FMI 3.0 ones (FMU3Slave):
pass --plant target/fmu/zmp_plant_fmi3.fmu --controller target/fmu/zmp_controller_fmi3.fmu.

Master algorithm (the same as `zmp_models::closed_loop::run`, so the traces agree with the
in-process simulation to rounding): at every controller sample t_k the master reads the plant's
ZMP, adds the load's effect (force plates see the ZMP of robot plus load), sets the controller's
inputs, reads its CoM reference (the controller's outputs depend directly on its inputs at a
sample instant), then steps the controller and the plant over [t_k, t_k + T]. The plant FMU
sub-steps internally with its fixed step h = 1 ms.
"""
import argparse
import json
import shutil
import sys

from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi3 import FMU3Slave

# The seed's experiment (zmp_models::closed_loop::StepExperiment::silo2()).
SILO2 = dict(
    zmp_ref_before=[0.12, 0.0],
    zmp_ref_after=[0.17, 0.0],
    load_time=80.0,
    load_mass=4.0,
    robot_mass=48.0,
    load_position=[0.30, 0.0],
    duration=160.0,
    controller_period=0.01,
)


class Slave:
    """One co-simulation FMU instance (FMI 2.0 or 3.0), variables addressed by name."""

    def __init__(self, filename, instance_name):
        md = read_model_description(filename)
        self.fmi3 = md.fmiVersion.startswith('3')
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.start = {v.name: float(v.start) for v in md.modelVariables
                      if v.start is not None and v.type in ('Real', 'Float64')}
        self.unzipdir = extract(filename)
        cls = FMU3Slave if self.fmi3 else FMU2Slave
        self.fmu = cls(guid=md.guid, unzipDirectory=self.unzipdir,
                       modelIdentifier=md.coSimulation.modelIdentifier,
                       instanceName=instance_name)
        self.fmu.instantiate()

    def set(self, names, values):
        vrs = [self.vr[n] for n in names]
        if self.fmi3:
            self.fmu.setFloat64(vrs, list(values))
        else:
            self.fmu.setReal(vrs, list(values))

    def get(self, names):
        vrs = [self.vr[n] for n in names]
        return self.fmu.getFloat64(vrs) if self.fmi3 else self.fmu.getReal(vrs)

    def initialize(self, start_time, parameters=None):
        if self.fmi3:
            if parameters:
                self.set(parameters.keys(), parameters.values())
            self.fmu.enterInitializationMode(startTime=start_time)
        else:
            self.fmu.setupExperiment(startTime=start_time)
            if parameters:
                self.set(parameters.keys(), parameters.values())
            self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()

    def step(self, t, h):
        self.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)

    def close(self):
        self.fmu.terminate()
        self.fmu.freeInstance()
        shutil.rmtree(self.unzipdir, ignore_errors=True)


def closed_loop(plant_fmu, controller_fmu, exp=SILO2, plant_parameters=None):
    """Runs the experiment; returns the trace as a dict of lists (one sample per period)."""
    plant = Slave(plant_fmu, 'plant')
    ctrl = Slave(controller_fmu, 'controller')
    try:
        # The FMUs' default start values are the experiment's initial operating point: the plant
        # at rest with its ZMP at 0.12 m, the controller's trunk upright there.
        plant.initialize(0.0, plant_parameters)
        ctrl.initialize(0.0, {'h': exp['controller_period']})

        def measure(z, t):
            if t >= exp['load_time']:
                m = exp['robot_mass'] + exp['load_mass']
                return [(exp['robot_mass'] * z[i] + exp['load_mass'] * exp['load_position'][i]) / m
                        for i in range(2)]
            return list(z)

        tc = exp['controller_period']
        n = round(exp['duration'] / tc)
        tr = {k: [] for k in ('t', 'zmp_ref', 'zmp', 'com_ref', 'com', 'theta')}
        for k in range(n + 1):
            t = k * tc
            zref = exp['zmp_ref_after'] if k > 0 else exp['zmp_ref_before']
            z = measure(plant.get(['zmp_x', 'zmp_y']), t)
            com = plant.get(['x_c', 'y_c'])
            ctrl.set(['zmp_ref_x', 'zmp_ref_y', 'zmp_x', 'zmp_y'], [zref[0], zref[1], z[0], z[1]])
            x_cr, y_cr, th_x, th_y = ctrl.get(['x_cr', 'y_cr', 'theta_x', 'theta_y'])
            tr['t'].append(t)
            tr['zmp_ref'].append(list(zref))
            tr['zmp'].append(z)
            tr['com_ref'].append([x_cr, y_cr])
            tr['com'].append(list(com))
            tr['theta'].append([th_x, th_y])
            if k < n:
                ctrl.step(t, tc)
                plant.set(['x_cr', 'y_cr'], [x_cr, y_cr])
                plant.step(t, tc)
        return tr
    finally:
        plant.close()
        ctrl.close()


def plot(tr, exp, out):
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    t = tr['t']
    fig, ax = plt.subplots(3, 1, sharex=True, figsize=(9, 8))
    ax[0].plot(t, [z[0] for z in tr['zmp_ref']], 'k--', label='ZMP reference')
    ax[0].plot(t, [z[0] for z in tr['zmp']], label='measured ZMP (x)')
    ax[0].axvline(exp['load_time'], color='grey', lw=0.8)
    ax[0].annotate(f"{exp['load_mass']:g} kg load", (exp['load_time'], 0.13), xytext=(5, 0),
                   textcoords='offset points')
    ax[0].set_ylabel('ZMP x [m]')
    ax[0].legend(loc='lower right')
    ax[1].plot(t, [c[0] for c in tr['com_ref']], label='CoM reference x_cr')
    ax[1].plot(t, [c[0] for c in tr['com']], label='CoM x_c')
    ax[1].set_ylabel('CoM x [m]')
    ax[1].legend(loc='lower right')
    ax[2].plot(t, [th[0] for th in tr['theta']])
    ax[2].set_ylabel('trunk angle x [rad]')
    ax[2].set_xlabel('time [s]')
    fig.suptitle('SILO2 ZMP cascade control: plant and controller FMUs in closed loop (FMPy)')
    fig.tight_layout()
    fig.savefig(out)
    print(f'wrote {out}')


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    p.add_argument('--plant', default='target/fmu/zmp_plant.fmu')
    p.add_argument('--controller', default='target/fmu/zmp_controller.fmu')
    p.add_argument('--out', default='fmpy_closed_loop.png', help='figure (.png or .svg)')
    p.add_argument('--json', help='also write the trace as JSON to this file')
    p.add_argument('--no-plot', action='store_true', help='skip the figure')
    p.add_argument('--experiment', help='JSON overriding fields of the experiment')
    a = p.parse_args(argv)
    exp = dict(SILO2)
    if a.experiment:
        exp.update(json.loads(a.experiment))
    tr = closed_loop(a.plant, a.controller, exp)
    if a.json:
        with open(a.json, 'w') as f:
            json.dump(tr, f)
    if not a.no_plot:
        plot(tr, exp, a.out)
    zx = [z[0] for z in tr['zmp']]
    reach = next((t for t, z in zip(tr['t'], zx) if z >= exp['zmp_ref_after'][0]), float('nan'))
    print(f'ZMP first reaches {exp["zmp_ref_after"][0]} m at t = {reach:.2f} s')
    return 0


if __name__ == '__main__':
    sys.exit(main())
