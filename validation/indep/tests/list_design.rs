//! Designs that list their records (`[[records]]`), the form the project's `design-next`
//! writes: read with errors naming the field, run as the grid runs the same records, on the
//! robot the seed and scenario draw for the default design.

use std::fs;
use zmp_indep_sim::{draw_for_design, simulate, AxisName, Design, ListedRecord, Scenario};

fn grid() -> Design {
    Design {
        operating_points: vec![[0.0, 0.0], [0.03, 0.02]],
        amplitudes: vec![0.003],
        omegas: vec![2.0, 9.0],
        excited: vec![AxisName::Y],
        transient_s: 1.0,
        periods: 2.0,
        min_steady_s: 2.0,
        seed: 7,
        ..Design::default()
    }
}

fn listed(g: &Design) -> Design {
    Design {
        operating_points: Vec::new(),
        amplitudes: Vec::new(),
        omegas: Vec::new(),
        excited: Vec::new(),
        records: g
            .records()
            .iter()
            .map(|r| ListedRecord {
                excited: r.excited,
                omega: r.omega,
                amplitude: r.amplitude,
                operating_point: r.operating_point,
            })
            .collect(),
        ..g.clone()
    }
}

#[test]
fn a_list_runs_its_records_as_the_grid_does_on_the_default_designs_robot() {
    let scenario: Scenario = "pair:time_delay,backlash".parse().unwrap();
    let g = grid();
    let l = listed(&g);
    assert_eq!(l.records(), g.records());
    // The list is run on the robot the default design draws; a grid on its own.
    let robot = draw_for_design(11, &scenario, &l);
    assert_eq!(robot, draw_for_design(11, &scenario, &Design::default()));
    let a = simulate(&robot, &g);
    let b = simulate(&robot, &l);
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.meta, y.meta);
        assert!(x.zmp_x == y.zmp_x && x.zmp_y == y.zmp_y);
    }
}

#[test]
fn a_list_is_read_from_a_file_and_its_errors_name_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("d.toml");
    // As design-next writes it: whole periods as an integer, the virtual robot's fields too.
    let head = "name = \"design-next\"\nsample_rate_hz = 200.0\ntransient_s = 3.0\n\
                periods = 4\nmin_steady_s = 7.96\nzmp_noise_std = 0.0005\n\
                quantisation = 0.0001\nseed = 1\n";
    let rec = |omega: &str| {
        format!(
            "\n[[records]]\nexcited = \"x\"\nomega = {omega}\namplitude = 0.002\n\
             operating_point = [0.02, 0.0]\n"
        )
    };
    fs::write(&path, format!("{head}{}{}", rec("25.0"), rec("3.5"))).unwrap();
    let d = Design::from_toml_file(&path).unwrap();
    assert_eq!(d.periods, 4.0);
    let r = d.records();
    assert_eq!(r.len(), 2);
    assert_eq!((r[0].omega, r[1].omega), (25.0, 3.5));
    assert_eq!(r[0].excited, AxisName::X);
    assert_eq!(r[0].operating_point, [0.02, 0.0]);
    assert_eq!(r[1].file(), "records/r001.csv");

    fs::write(&path, format!("{head}{}{}", rec("25.0"), rec("-1.0"))).unwrap();
    let e = Design::from_toml_file(&path).unwrap_err().to_string();
    assert!(
        e.contains("d.toml") && e.contains("records[1].omega"),
        "{e}"
    );
    fs::write(&path, format!("{head}omegas = [1.0]\n{}", rec("2.0"))).unwrap();
    let e = Design::from_toml_file(&path).unwrap_err().to_string();
    assert!(e.contains("d.toml") && e.contains("not both"), "{e}");
    fs::write(
        &path,
        format!("{head}{}", rec("2.0").replace("omega =", "omgea =")),
    )
    .unwrap();
    let e = Design::from_toml_file(&path).unwrap_err().to_string();
    assert!(e.contains("d.toml") && e.contains("omgea"), "{e}");
}
