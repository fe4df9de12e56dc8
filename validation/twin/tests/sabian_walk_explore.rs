use zmp_models::walking::Gait;
use zmp_twin::sabian::calibrate::FOOT_SPACING;
use zmp_twin::sabian::experiment::*;

#[test]
fn explore_walk() {
    let mut opt = Options::quick();
    opt.runs = 2;
    opt.draws = 5;
    let t = std::time::Instant::now();
    let cal = calibrate(&opt).unwrap();
    eprintln!(
        "cal in {:?}: ours {:.2} mm h {:.2} mm v; seed {:.2} / {:.2}; zeroed {:.2}/{:.2}",
        t.elapsed(),
        cal.designed.rms_horizontal_m * 1e3,
        cal.designed.rms_vertical_m * 1e3,
        cal.seed.rms_horizontal_m * 1e3,
        cal.seed.rms_vertical_m * 1e3,
        cal.seed_zeroed.rms_horizontal_m * 1e3,
        cal.seed_zeroed.rms_vertical_m * 1e3
    );
    eprintln!(
        "true com {:?} cad {:?} est {:?}",
        cal.true_com, cal.cad_com, cal.estimated_com
    );
    let models = virtual_models(&cal);
    for m in &models {
        eprintln!("falls model {} {:?}", m.name, m.error_mass);
    }
    eprintln!(
        "falls est pos {:?} m {}",
        cal.estimated_error_mass_position, cal.estimated_error_mass_kg
    );
    let gait = Gait::seed(FOOT_SPACING);
    let t = std::time::Instant::now();
    let out = walk_models(&models, &opt, &gait).unwrap();
    eprintln!("walked in {:?}", t.elapsed());
    for m in &out {
        eprintln!(
            "{} falls {} clear {:.3} rtf {:.1} bias {:?} rms_pos {:?} corr {:?} roll {:?}",
            m.name,
            m.falls,
            m.min_clearance_m,
            m.real_time_factor,
            m.mean.bias,
            m.mean.rms_pos,
            m.mean.corr_pos,
            m.mean.roll_pos
        );
    }
}
