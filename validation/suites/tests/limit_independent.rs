//! The identification's acceleration limit on a robot of the independent simulator
//! (`zmp-indep-sim`, which shares no physics code with this crate) whose limit's misfit has
//! two valleys.
//!
//! Held-out draw 1120002 (examined after its range was run): a lone Coulomb friction on a
//! fast servo (38.8 rad/s, zeta 0.83) with the seed's force limit at 1.255 m/s2. The friction
//! bends the faster records of both amplitudes off the linear model, so they are flagged with
//! the 8 mm sines the limit clips; over that set the limit's chi-square has a shallow valley
//! near a quarter of the drawn limit and the deep one at it. Brent's method over the whole
//! range settled in the shallow one (0.309 m/s2): the identified model was 45x its noise
//! floor and the loop ended at 61x, naming a delay and a mode. The search now starts from a
//! grid (`identify::saturation_limit::bracket`).

use zmp_suites::indep_loop;

use zmp_identify::{identify, IdentifyOptions};

const SEED: u64 = 1_120_002;
const SCENARIO: &str = "single:coulomb_friction";

#[test]
fn the_limit_search_finds_the_deep_valley() {
    let drawn = indep_loop::drawn_campaign(SEED, SCENARIO);
    let limit_of = |k: usize| drawn.robot.axes[k].servo.accel_limit;
    let drawn_limit = limit_of(0);
    assert_eq!(drawn_limit, limit_of(1), "one limit per robot");
    let ident = identify(&drawn.campaign, &IdentifyOptions::default()).unwrap();
    let limit = ident.saturation.limit.expect("a limit estimated");
    assert!(
        (limit / drawn_limit - 1.0).abs() < 0.03,
        "limit {limit:.4} m/s2 against the drawn {drawn_limit:.4}"
    );
}
