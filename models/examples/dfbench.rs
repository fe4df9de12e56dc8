//! Time of one servo describing function with Coulomb friction (and saturation), by level,
//! regularisation speed and frequency: a development aid for the diagnosis's costs.
use zmp_models::effect::{BuildContext, Effect};
use zmp_models::effects::servo::clear_describing_function_cache;
use zmp_models::EffectKind;
use zmp_models::{Axis, Binding};
fn main() {
    saturation_with_link();
    let ctx = BuildContext {
        h: 0.001,
        binding: Binding::Axis(Axis::X),
        servo: Some((30.0, 1.0)),
        link: None,
    };
    for &(level, vs) in &[
        (0.05, 1e-4),
        (0.3, 1e-4),
        (1.0, 1e-4),
        (2.5, 1e-4),
        (1.0, 1e-3),
    ] {
        for &omega in &[0.5, 2.0, 15.0] {
            clear_describing_function_cache();
            let f: Box<dyn Effect> = (EffectKind::CoulombFriction.info().build)(&ctx, &[level, vs]);
            let t = std::time::Instant::now();
            let g = f.frequency_response(omega, 0.003);
            println!(
                "level {level} v_s {vs} omega {omega}: {:.3} ms |g| {:.4}",
                t.elapsed().as_secs_f64() * 1e3,
                g.norm()
            );
        }
    }
}

/// The saturation's describing function on a rigid trunk and on a flexible one (the two-body
/// loop), at 1.5x and 3x the linear force.
fn saturation_with_link() {
    use zmp_models::effects::servo_link::TrunkLink;
    let link = TrunkLink::flexible(14.0, 0.08, 0.35, 0.29);
    for link in [None, Some(link)] {
        let ctx = BuildContext {
            h: 0.001,
            binding: Binding::Axis(Axis::X),
            servo: Some((25.0, 0.9)),
            link,
        };
        for &(kind, value) in &[
            (EffectKind::AccelerationSaturation, 0.5),
            (EffectKind::CoulombFriction, 0.3),
            (EffectKind::CoulombFriction, 2.5),
        ] {
            for &omega in &[0.5, 3.0, 9.0, 15.0] {
                for &amp in &[0.003, 0.008] {
                    clear_describing_function_cache();
                    let f: Box<dyn Effect> = (kind.info().build)(&ctx, &[value]);
                    let t = std::time::Instant::now();
                    let g = f.frequency_response(omega, amp);
                    println!(
                    "{kind} {value}, link {}: omega {omega} amplitude {amp}: {:.3} ms |g| {:.4}",
                    link.is_some(),
                    t.elapsed().as_secs_f64() * 1e3,
                    g.norm()
                );
                }
            }
        }
    }
}
