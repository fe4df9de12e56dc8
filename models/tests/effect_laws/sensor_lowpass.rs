//! `sensor_lowpass`: -3 dB and -45 degrees at the cutoff.

use crate::support::plant;
use zmp_models::Axis;

/// `wc/(s + wc)`: -3 dB and -45 degrees at the cutoff.
#[test]
fn sensor_lowpass_is_minus_3_db_and_minus_45_degrees_at_cutoff() {
    let mut base = plant("");
    for cutoff in [5.0, 20.0, 80.0] {
        let mut p = plant(&format!("[sensor_lowpass]\ncutoff = {cutoff}\n"));
        let r = p.frequency_response(cutoff)[1][0] / base.frequency_response(cutoff)[1][0];
        assert!(
            (20.0 * r.norm().log10() + 3.010_299_956_639_812).abs() < 1e-9,
            "{r}"
        );
        assert!((r.arg().to_degrees() + 45.0).abs() < 1e-9, "{r}");
        let s = p.simulated_response(Axis::X, cutoff, 0.01);
        let s0 = base.simulated_response(Axis::X, cutoff, 0.01);
        for i in 0..2 {
            let r = s[i] / s0[i];
            let db = 20.0 * r.norm().log10();
            assert!(
                (db + 3.0103).abs() < 0.02,
                "cutoff {cutoff}, output {i}: {db} dB"
            );
            assert!(
                (r.arg().to_degrees() + 45.0).abs() < 0.2,
                "cutoff {cutoff}, output {i}: {} deg",
                r.arg().to_degrees()
            );
        }
    }
}
