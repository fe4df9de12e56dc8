//! The one criterion of the diagnosis.
//!
//! **Held-out chi-square.** The records are split into two folds by frequency ([`folds`]); a
//! structure is fitted on each fold and predicts the other, so every record has a chi-square
//! from a model that was not fitted on it (`chi2_k`, about its component count for a right
//! model; overfitting only raises it, so no per-parameter penalty is needed).
//!
//! **The comparison** ([`compare`]) of two structures A and B is the likelihood ratio of their
//! held-out predictions, `D = chi2(B) - chi2(A)` (both summed over the records), against its
//! spread under the noise. With `r_A`, `r_B` the two residual vectors (each component over its
//! noise), `D = 2 r_A . delta + |delta|^2` with `delta = r_B - r_A` the distance between the
//! two predictions in noise standard deviations: if A is right, `D` is `|delta|^2` on average
//! with standard deviation `2 |delta|`; if B is right, `-|delta|^2`. So
//!
//! ```text
//! z = (chi2(B) - chi2(A)) / (2 sqrt(c) |r_B - r_A|)
//! ```
//!
//! and A is significantly better than B when `z > z_(1 - alpha/m)`: the standard normal
//! quantile at the significance level [`ALPHA`] shared over the `m` structures a search
//! compares (Bonferroni: the chance that any structure passes on noise alone is at most
//! `ALPHA`). `c >= 1` is the mismatch factor, the best structure's held-out chi-square per
//! component: where even the best model leaves more than the noise, its residual counts as
//! noise of that size (quasi-likelihood, McCullagh and Nelder). This is Cox's test of two
//! hypotheses, nested (a structure and itself with one more effect) or not (a play against a
//! friction), for Gaussian noise of known variance. Two structures whose predictions on the
//! campaign differ by less than `2 sqrt(c) z` standard deviations in all can never be
//! separated by it: the records do not decide between them, and new records where they part
//! would (`words::distinguish`).
//!
//! **The size of the difference.** Cox's `z` takes the residual along `delta` for noise of
//! variance `c`. Where the best model leaves a misfit that is not noise, the misfit has a
//! direction, and two predictions a hair apart along it give a large `z` on a chi-square
//! difference of a thousandth (a force limit that barely acts, a drift rate of zero). So the
//! difference itself must also be one that a likelihood-ratio test of one added parameter at
//! the same level would accept, `D / c > z^2` (a chi-square of one degree of freedom at `2
//! alpha/m` is the square of the one-sided normal quantile at `alpha/m`). The statistic is
//!
//! ```text
//! z_eff = min(z, sign(D) sqrt(|D| / c))
//! ```
//!
//! against the same threshold: both tests at level `alpha/m` must reject, so their
//! intersection is a test at that level too (Berger's intersection-union test).
//!
//! **Nuisance parameters.** A few components are not held out: a record's own trend under a
//! drift per record (a sensor re-zeroed at every record), whose rate no other record predicts,
//! is fitted on that record itself (`HeldOut::nuisance` counts them). Where the better-fitting
//! structure has `k` such parameters more than the other, the likelihood-ratio side is the
//! test of `k` added parameters at the same level, `P(chi2_k > D / c) < alpha / m`, through the
//! normal deviate of `D / c` on `k` degrees of freedom (Wilson and Hilferty); the mismatch
//! factor counts only the components held out. Against a structure with one rate, this is
//! Cochran's test of heterogeneity of the records' trends.
//!
//! **Neither.** Cox's test, centred on each hypothesis in turn, also says when the records
//! reject both: if A were the whole truth, `D` would be `|delta|^2` give or take
//! `2 sqrt(c) |delta|`; if B were, `-|delta|^2`. So
//!
//! ```text
//! t_A = (D - |delta|^2) / (2 sqrt(c) |delta|),    t_B = (D + |delta|^2) / (2 sqrt(c) |delta|)
//! ```
//!
//! are standard normal under A and under B respectively, and `t_A < -z` and `t_B > z`
//! ([`Comparison::neither`]) reject each at the same level. Two structures whose predictions
//! part by many standard deviations and that fit the records about equally are then not what
//! the records cannot decide between: the records decide, against both (each leaves a misfit
//! along the direction that parts them, which the other half-fits). That takes
//! `|delta| > 2 sqrt(c) z`; below it no outcome rejects both, and a `D` near zero means the
//! records hold too little to part them (the ambiguity set, and the experiment that decides).

use crate::measure::{aggregate, predict, score, whitened, RecordScore};
use crate::observe::Observation;
use zmp_models::ModelSpec;

/// The significance level of every decision of the diagnosis.
pub const ALPHA: f64 = 0.01;

/// The two folds: `fold[k]` is true for records in the second one. At each frequency the
/// records, ordered by excited axis, amplitude and operating point, alternate between the
/// folds, the first of them alternating with the frequency: each fold holds every frequency,
/// amplitude and axis once the campaign has two records per frequency, and an effect acting on
/// a few records (saturation on the fastest, largest) is fitted on some and judged on others.
pub fn folds(obs: &[&Observation]) -> Vec<bool> {
    let omegas = distinct_omegas(obs);
    let mut fold = vec![false; obs.len()];
    for (q, w) in omegas.iter().enumerate() {
        let mut at: Vec<usize> = (0..obs.len())
            .filter(|&k| (obs[k].omega - w).abs() <= 1e-9 * w.abs())
            .collect();
        at.sort_by(|&a, &b| {
            let (x, y) = (obs[a], obs[b]);
            x.excited
                .index()
                .cmp(&y.excited.index())
                .then(x.nominal_amplitude.total_cmp(&y.nominal_amplitude))
                .then(x.operating_point[0].total_cmp(&y.operating_point[0]))
                .then(x.operating_point[1].total_cmp(&y.operating_point[1]))
                .then(a.cmp(&b))
        });
        for (r, &k) in at.iter().enumerate() {
            fold[k] = (r + q) % 2 == 1;
        }
    }
    fold
}

/// The records of fold `f` (0 or 1) and those of the other.
pub fn split<'a>(obs: &[&'a Observation], f: usize) -> (Vec<&'a Observation>, Vec<usize>) {
    let fold = folds(obs);
    let train = (0..obs.len())
        .filter(|&k| fold[k] == (f == 1))
        .map(|k| obs[k])
        .collect();
    let test = (0..obs.len()).filter(|&k| fold[k] != (f == 1)).collect();
    (train, test)
}

/// The distinct excitation frequencies, ascending.
pub fn distinct_omegas(obs: &[&Observation]) -> Vec<f64> {
    let mut omegas: Vec<f64> = obs.iter().map(|o| o.omega).collect();
    omegas.sort_by(f64::total_cmp);
    omegas.dedup_by(|a, b| (*a - *b).abs() <= 1e-9 * b.abs());
    omegas
}

/// A structure's records scored by models not fitted on them.
#[derive(Debug, Clone, PartialEq)]
pub struct HeldOut {
    /// Per record (observation order): its residual components over their noise
    /// (`measure::whitened`).
    pub residuals: Vec<Vec<f64>>,
    /// Per record: the chi-square of its whitened residuals (sum of their squares).
    pub chi2s: Vec<f64>,
    /// Per record: its squared error and squared noise floor (the error measure).
    pub scores: Vec<RecordScore>,
    /// Sum of `chi2s`: the structure's held-out chi-square, the score the search compares.
    pub chi2: f64,
    /// The campaign's held-out error (RMS over records of the error measure).
    pub error: f64,
    /// Residual components fitted on the record they belong to rather than held out: a
    /// record's own trend under a per-record drift (a nuisance parameter each; [`compare`]
    /// counts them as degrees of freedom).
    pub nuisance: usize,
}

impl HeldOut {
    /// The held-out scores of two fold fits: `fits[f]` fitted on fold `f`'s records predicts
    /// the others. `None` when a prediction fails.
    pub fn of(fits: [&ModelSpec; 2], obs: &[&Observation]) -> Option<HeldOut> {
        let mut chi2s = vec![f64::NAN; obs.len()];
        let mut residuals = vec![Vec::new(); obs.len()];
        let mut scores = vec![
            RecordScore {
                error2: f64::NAN,
                floor2: f64::NAN
            };
            obs.len()
        ];
        let mut nuisance = 0;
        for (f, spec) in fits.iter().enumerate() {
            let (_, test) = split(obs, f);
            let recs: Vec<&Observation> = test.iter().map(|&k| obs[k]).collect();
            let own = (0..2)
                .filter(|&i| crate::profiles::drift_per_record(spec, i))
                .count();
            nuisance += own * recs.len();
            let p = predict(spec, &recs).ok()?;
            for ((&k, o), pr) in test.iter().zip(&recs).zip(&p) {
                whitened(o, pr, &mut residuals[k]);
                chi2s[k] = residuals[k].iter().map(|x| x * x).sum();
                scores[k] = score(o, pr);
            }
        }
        let complete =
            chi2s.iter().all(|c| c.is_finite()) && scores.iter().all(|s| s.error2.is_finite());
        complete.then(|| HeldOut {
            chi2: chi2s.iter().sum(),
            error: aggregate(&scores).0,
            residuals,
            chi2s,
            scores,
            nuisance,
        })
    }

    /// Residual components in all.
    pub fn components(&self) -> usize {
        self.residuals.iter().map(|r| r.len()).sum()
    }

    /// Its mismatch factor: held-out chi-square per component held out, at least 1.
    pub fn mismatch(&self) -> f64 {
        let held = self.components().saturating_sub(self.nuisance).max(1);
        (self.chi2 / held as f64).max(1.0)
    }
}

/// The likelihood ratio of two structures' held-out predictions against its noise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Comparison {
    /// `chi2(B) - chi2(A)`: positive where A predicts the held-out records better.
    pub difference: f64,
    /// `|r_B - r_A|`: how far apart the two predictions are, in noise standard deviations.
    pub distance: f64,
    /// `min(difference / (2 sqrt(c) distance), sign(difference) sqrt(|difference| / c))`: the
    /// smaller of Cox's statistic and the likelihood ratio's (0 for identical predictions).
    pub z: f64,
    /// `2 sqrt(c) distance`: the standard deviation of `difference` under either structure.
    pub spread: f64,
}

impl Comparison {
    /// Whether A is significantly better than B at threshold `z_crit` ([`threshold`]).
    pub fn better(&self, z_crit: f64) -> bool {
        self.z > z_crit
    }

    /// Cox's statistics centred on each structure: `(t_A, t_B)`, standard normal if A
    /// (respectively B) is the whole truth; `(0, 0)` for identical predictions.
    pub fn centred(&self) -> (f64, f64) {
        if self.spread <= 0.0 {
            return (0.0, 0.0);
        }
        let expected = self.distance * self.distance;
        (
            (self.difference - expected) / self.spread,
            (self.difference + expected) / self.spread,
        )
    }

    /// Whether the records reject both structures at threshold `z_crit`: they part them, yet
    /// fit neither as either would fit them were it the whole truth (module documentation).
    pub fn neither(&self, z_crit: f64) -> bool {
        let (t_a, t_b) = self.centred();
        t_a < -z_crit && t_b > z_crit
    }
}

/// The criterion: A (`a`) against B (`b`) on the same records, with mismatch factor `c`.
pub fn compare(a: &HeldOut, b: &HeldOut, c: f64) -> Comparison {
    let difference = b.chi2 - a.chi2;
    let distance = a
        .residuals
        .iter()
        .zip(&b.residuals)
        .flat_map(|(x, y)| x.iter().zip(y).map(|(p, q)| (q - p) * (q - p)))
        .sum::<f64>()
        .sqrt();
    let c = c.max(1.0);
    // Nuisance parameters of the better-fitting side: its likelihood ratio on that many
    // degrees of freedom (module documentation).
    let extra = if difference < 0.0 {
        b.nuisance.saturating_sub(a.nuisance)
    } else {
        a.nuisance.saturating_sub(b.nuisance)
    };
    let z = if distance > 0.0 {
        let cox = difference / (2.0 * c.sqrt() * distance);
        let lr = if extra > 0 {
            difference.signum() * chi2_deviate(difference.abs() / c, extra as f64)
        } else {
            difference.signum() * (difference.abs() / c).sqrt()
        };
        cox.min(lr)
    } else {
        0.0
    };
    Comparison {
        difference,
        distance,
        z,
        spread: 2.0 * c.sqrt() * distance,
    }
}

/// The separation, in noise standard deviations, at which the criterion at threshold
/// `z_crit` and mismatch factor `c` prefers the true one of two structures with probability
/// `1 - ALPHA`: with A true, Cox's statistic is normal with mean `|delta| / (2 sqrt(c))` and
/// unit standard deviation (the likelihood ratio's `sqrt(D / c)` is larger), so
/// `|delta| = 2 sqrt(c) (z_crit + z_(1 - ALPHA))`. What a designed experiment aims for.
pub fn decisive_separation(z_crit: f64, c: f64) -> f64 {
    2.0 * c.max(1.0).sqrt() * (z_crit + z_one_sided(ALPHA))
}

/// The threshold of a search comparing `m` structures: the one-sided standard normal quantile
/// at [`ALPHA`]` / m`.
pub fn threshold(m: usize) -> f64 {
    z_one_sided(ALPHA / m.max(1) as f64)
}

/// The standard normal quantile exceeded with probability `p` (`z` with `P(Z > z) = p`).
pub fn z_one_sided(p: f64) -> f64 {
    -normal_quantile(p)
}

/// The standard normal quantile function (`zmp_identify::normal_quantile`, Acklam's rational
/// approximation, relative error below 1.2e-9 on (0, 1)), kept finite at the ends.
pub fn normal_quantile(p: f64) -> f64 {
    zmp_identify::normal_quantile(p.clamp(1e-300, 1.0 - 1e-16))
}

/// The standard normal deviate of a chi-square value `x` on `nu` degrees of freedom: `z` with
/// `P(Z > z) = P(chi2_nu > x)` (Wilson-Hilferty, the inverse of [`chi2_quantile`]).
pub fn chi2_deviate(x: f64, nu: f64) -> f64 {
    let h = 2.0 / (9.0 * nu);
    ((x / nu).cbrt() - (1.0 - h)) / h.sqrt()
}

/// The chi-square quantile with `nu` degrees of freedom exceeded with probability `p`
/// (Wilson-Hilferty: within 1 % of the exact quantile from `nu = 3` at `p = 0.01`).
pub fn chi2_quantile(nu: f64, p: f64) -> f64 {
    let h = 2.0 / (9.0 * nu);
    nu * (1.0 - h + z_one_sided(p) * h.sqrt()).powi(3).max(0.0)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A held-out result of residual vectors (one component per record).
    fn held(r: Vec<f64>) -> HeldOut {
        HeldOut {
            chi2: r.iter().map(|x| x * x).sum(),
            error: 0.0,
            scores: Vec::new(),
            chi2s: r.iter().map(|x| x * x).collect(),
            residuals: r.into_iter().map(|x| vec![x]).collect(),
            nuisance: 0,
        }
    }

    /// A deterministic standard normal sample (Box-Muller over a linear congruential
    /// generator).
    pub(crate) fn normals(n: usize, mut state: u64) -> Vec<f64> {
        let mut u = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        (0..n)
            .map(|_| (-2.0 * u().ln()).sqrt() * (2.0 * std::f64::consts::PI * u()).cos())
            .collect()
    }

    /// Nuisance parameters fitted on the records they predict: noise alone in them (each
    /// record's residual taken away, as a per-record trend takes its own) is not a significant
    /// gain on their degrees of freedom; a real record-to-record spread is.
    #[test]
    fn nuisance_parameters_count_as_degrees_of_freedom() {
        let n = 200;
        let noise = normals(n, 7);
        let parent = held(noise.clone());
        let mut own = held(vec![0.0; n]);
        own.nuisance = n;
        let z_crit = threshold(20);
        // Each record's own value absorbs its noise: chi-square 200 -> 0, Cox's z alone
        // would be sqrt(200) / 2 = 7.
        let cmp = compare(&own, &parent, 1.0);
        assert!(cmp.difference > 150.0, "{cmp:?}");
        assert!(!cmp.better(z_crit), "noise taken for an effect: {cmp:?}");
        // The same gain without counting the nuisance parameters would pass.
        let mut free = own.clone();
        free.nuisance = 0;
        assert!(compare(&free, &parent, 1.0).better(z_crit));
        // Record-to-record values of three noise standard deviations: significant.
        let spread: Vec<f64> = normals(n, 8)
            .iter()
            .zip(&noise)
            .map(|(a, b)| 3.0 * a + b)
            .collect();
        let cmp = compare(&own, &held(spread), 1.0);
        assert!(cmp.better(z_crit), "{cmp:?}");
        // The deviate inverts the quantile.
        for nu in [5.0, 50.0, 500.0] {
            let x = chi2_quantile(nu, 0.001);
            assert!(
                (chi2_deviate(x, nu) - z_one_sided(0.001)).abs() < 1e-9,
                "{nu}"
            );
        }
        // The mismatch factor counts the held-out components only.
        let mut half = held(vec![2.0; 10]);
        half.nuisance = 5;
        assert!((half.mismatch() - 8.0).abs() < 1e-12);
    }

    /// At the decisive separation the criterion prefers the true structure with probability
    /// `1 - ALPHA`: 2000 draws of noise (scaled by `sqrt(c)`, a misfit the models share, at
    /// `c` = 1 and 4) on 50 components, the rival's residual parted from the truth's by
    /// `decisive_separation(z, c)` along a fixed direction; the share of draws where the truth
    /// is significantly better lies within three binomial standard deviations of 99 % (0.2 %).
    /// At 5 noise standard deviations (Cox's mean 2.5 under the threshold 3.54 of 50
    /// structures) it is about 15 %.
    #[test]
    fn the_decisive_separation_decides_with_the_stated_probability() {
        let z = threshold(50);
        let dir = normals(50, 7);
        let norm = dir.iter().map(|x| x * x).sum::<f64>().sqrt();
        let share = |c: f64, sep: f64| {
            let wins = (0..2000)
                .filter(|&k| {
                    let e: Vec<f64> = normals(50, 1000 + k).iter().map(|x| x * c.sqrt()).collect();
                    let b: Vec<f64> = e
                        .iter()
                        .zip(&dir)
                        .map(|(x, u)| x + sep * u / norm)
                        .collect();
                    compare(&held(e), &held(b), c).better(z)
                })
                .count();
            wins as f64 / 2000.0
        };
        for c in [1.0, 4.0] {
            let p = share(c, decisive_separation(z, c));
            assert!((0.983..=0.997).contains(&p), "c {c}: {p}");
        }
        let p = share(1.0, 5.0);
        assert!((0.05..0.2).contains(&p), "{p}");
    }

    /// The quantiles against tables: z at 5 %, 1 %, 0.1 %; the symmetric side; chi-square.
    #[test]
    fn the_thresholds_follow_the_significance_level() {
        for (p, z) in [
            (0.05, 1.644_853_6),
            (0.01, 2.326_347_9),
            (0.001, 3.090_232_3),
        ] {
            assert!((z_one_sided(p) - z).abs() < 1e-7, "{p}");
            assert!((normal_quantile(1.0 - p) - z).abs() < 1e-7);
        }
        assert!((normal_quantile(0.5)).abs() < 1e-12);
        // Shared over ten structures: the quantile at 0.1 %.
        assert!((threshold(10) - 3.090_232_3).abs() < 1e-7);
        assert!(threshold(100) > threshold(10) && threshold(10) > threshold(1));
        // chi2(0.99; 6) = 16.81, chi2(0.99; 100) = 135.81.
        assert!((chi2_quantile(6.0, 0.01) / 16.812 - 1.0).abs() < 0.01);
        assert!((chi2_quantile(100.0, 0.01) / 135.807 - 1.0).abs() < 0.002);
    }

    /// Two structures whose held-out predictions part by 20 standard deviations while the
    /// records' misfit lies halfway between them (each misses by 10 along the direction that
    /// parts them): neither is better, and Cox's test centred on each rejects both. With A
    /// the truth, B is worse and A is not rejected. Parting by 3 standard deviations (under
    /// `2 sqrt(c) z`), no outcome rejects both.
    #[test]
    fn records_that_part_two_structures_and_fit_neither_reject_both() {
        let noise = normals(200, 31);
        let dir = normals(200, 32);
        let norm = dir.iter().map(|x| x * x).sum::<f64>().sqrt();
        let along = |k: f64| -> Vec<f64> {
            noise
                .iter()
                .zip(&dir)
                .map(|(e, u)| e + k * u / norm)
                .collect()
        };
        let z = threshold(10);
        let (a, b) = (held(along(10.0)), held(along(-10.0)));
        let c = a.mismatch().min(b.mismatch());
        let ab = compare(&a, &b, c);
        assert!((ab.distance - 20.0).abs() < 1e-9, "{ab:?}");
        assert!(!ab.better(z) && !compare(&b, &a, c).better(z), "{ab:?}");
        assert!(ab.neither(z) && compare(&b, &a, c).neither(z), "{ab:?}");
        let (a, b) = (held(along(0.0)), held(along(-20.0)));
        let ab = compare(&a, &b, a.mismatch());
        let (t_a, t_b) = ab.centred();
        assert!(ab.better(z) && !ab.neither(z), "{ab:?}");
        assert!(t_a.abs() < z && t_b > z, "{t_a} {t_b}");
        let (a, b) = (held(along(1.5)), held(along(-1.5)));
        for c in [1.0, 2.0] {
            let ab = compare(&a, &b, c);
            assert!(!ab.neither(z) && !ab.better(z), "{ab:?}");
        }
    }

    /// A structure that adds only noise to its parent's predictions (here 400 parents and
    /// children of 108 records, the child's predictions moved at random by half a standard
    /// deviation) passes the 1 % threshold less than 1 % of the time (the statistic is at most
    /// a standard normal deviate under noise, lower for a child that only adds noise); one that
    /// removes a misfit from a few records passes whatever the other records do.
    #[test]
    fn a_structure_that_adds_only_noise_is_not_selected() {
        let z = threshold(1);
        let mut passed = 0;
        for trial in 0..400u64 {
            let noise = normals(108, 17 + trial);
            let moved = normals(108, 1_000_003 + trial);
            let parent = held(noise.clone());
            let child = held(noise.iter().zip(&moved).map(|(e, m)| e + 0.5 * m).collect());
            if compare(&child, &parent, 1.0).better(z) {
                passed += 1;
            }
        }
        // Binomial(400, 0.01) is at most 10 with probability above 99.9 %.
        assert!(passed <= 10, "{passed} of 400 passed on noise alone");
        // The parent misses 8 of 108 records by 6 standard deviations; the child does not.
        let noise = normals(108, 5);
        let miss: Vec<f64> = (0..108)
            .map(|k| if k % 13 == 0 { 6.0 } else { 0.0 })
            .collect();
        let parent = held(noise.iter().zip(&miss).map(|(e, m)| e + m).collect());
        let child = held(noise.clone());
        let c = compare(&child, &parent, 1.0);
        assert!(c.better(threshold(100)), "{c:?}");
        // Twice the mismatch factor lowers the statistic by sqrt(2).
        assert!((compare(&child, &parent, 2.0).z * 2f64.sqrt() - c.z).abs() < 1e-9);
        // Identical predictions: no difference at any level, either way.
        assert_eq!(compare(&parent, &parent, 1.0).z, 0.0);
    }

    /// A misfit that is not noise (every record missed by 5 standard deviations the same way,
    /// the mismatch factor about 26) and a child whose predictions move a thousandth of a
    /// standard deviation along it: Cox's statistic alone is large (the residual along that
    /// direction is the misfit, not noise of variance c), the chi-square difference is a
    /// few hundredths of c, and the criterion does not take it. Moved by one standard deviation, the
    /// child removes a fifth of the misfit and passes.
    #[test]
    fn a_hair_along_a_systematic_misfit_is_not_an_effect() {
        let noise = normals(108, 11);
        let parent: Vec<f64> = noise.iter().map(|e| e + 5.0).collect();
        let c = parent.iter().map(|x| x * x).sum::<f64>() / 108.0;
        let moved = |by: f64| held(parent.iter().map(|r| r - by).collect());
        let hair = compare(&moved(1e-3), &held(parent.clone()), c);
        let cox = hair.difference / (2.0 * c.sqrt() * hair.distance);
        assert!(cox > threshold(100), "{hair:?}");
        assert!(
            hair.difference / c < 0.1 && !hair.better(threshold(100)),
            "{hair:?}"
        );
        let step = compare(&moved(1.0), &held(parent), c);
        assert!(step.better(threshold(100)), "{step:?}");
    }

    /// The folds alternate at every frequency and over frequencies.
    #[test]
    fn each_fold_holds_every_frequency() {
        use num_complex::Complex64;
        let rec = |k: usize, omega: f64, amp: f64| Observation {
            index: k,
            excited: zmp_models::Axis::X,
            omega,
            operating_point: [0.0; 2],
            nominal_amplitude: amp,
            t0: 0.0,
            t1: 1.0,
            u1: Complex64::new(amp, 0.0),
            y1: [Complex64::new(amp, 0.0); 2],
            y1_var: [1e-10; 2],
            y3: [Complex64::new(0.0, 0.0); 2],
            y3_var: [1e-12; 2],
            third_band: false,
            slope: [0.0; 2],
            slope_var: [1e-12; 2],
            noise_std: [1e-4; 2],
            samples: 100,
        };
        let v: Vec<Observation> = (0..8)
            .map(|k| rec(k, [1.0, 2.0, 4.0, 8.0][k / 2], [0.003, 0.008][k % 2]))
            .collect();
        let refs: Vec<&Observation> = v.iter().collect();
        assert_eq!(
            folds(&refs),
            vec![false, true, true, false, false, true, true, false]
        );
        let (train, test) = split(&refs, 1);
        assert_eq!(train.len(), 4);
        assert_eq!(test, vec![0, 3, 4, 7]);
    }
}
