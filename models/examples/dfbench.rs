//! Time of one servo describing function with Coulomb friction (and saturation), by level,
//! regularisation speed and frequency: a development aid for the diagnosis's costs.
use zmp_models::effect::{BuildContext, Effect};
use zmp_models::effects::servo::clear_describing_function_cache;
use zmp_models::{lookup, Axis, Binding};
fn main() {
    let ctx = BuildContext {
        h: 0.001,
        binding: Binding::Axis(Axis::X),
        servo: Some((30.0, 1.0)),
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
            let f: Box<dyn Effect> =
                (lookup("coulomb_friction").unwrap().build)(&ctx, &[level, vs]);
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
