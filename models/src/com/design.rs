//! Posture design: choose N postures from candidates (already filtered to those whose CoM stays
//! inside the support polygon, about +/- 5 degrees of tilt) to maximise the determinant of the
//! stacked system's information (D-optimality), and report its condition number.
//!
//! Greedy forward selection followed by exchange passes (Fedorov): every chosen posture is
//! swapped with every unchosen one while that raises `log det`. The information matrices are
//! additive over independent postures.

use super::wrench::ComError;
use nalgebra::DMatrix;

/// The chosen postures (candidate indices, in the order chosen) and the design's figures.
#[derive(Debug, Clone, PartialEq)]
pub struct DesignChoice {
    /// Indices of the chosen candidate postures, in the order chosen.
    pub chosen: Vec<usize>,
    /// `log det` of the summed information.
    pub log_det: f64,
    /// Condition number of the summed information's square root (that of the whitened stacked
    /// system), with the unknowns scaled to unit diagonal.
    pub condition_number: f64,
}

/// `log det` of a symmetric positive-definite matrix, `-inf` if it is not.
pub fn log_det(m: &DMatrix<f64>) -> f64 {
    match m.clone().cholesky() {
        Some(c) => 2.0 * c.l().diagonal().iter().map(|v| v.ln()).sum::<f64>(),
        None => f64::NEG_INFINITY,
    }
}

/// The condition number of `sqrt(info)` after scaling to unit diagonal.
pub fn condition_number(info: &DMatrix<f64>) -> f64 {
    let n = info.nrows();
    let d: Vec<f64> = (0..n).map(|k| info[(k, k)].max(1e-300).sqrt()).collect();
    let scaled = DMatrix::from_fn(n, n, |r, c| info[(r, c)] / (d[r] * d[c]));
    let eig = scaled.symmetric_eigen().eigenvalues;
    let hi = eig.max();
    let lo = eig.min();
    if lo <= 0.0 {
        f64::INFINITY
    } else {
        (hi / lo).sqrt()
    }
}

fn sum(infos: &[DMatrix<f64>], set: &[usize]) -> DMatrix<f64> {
    let n = infos[0].nrows();
    set.iter()
        .fold(DMatrix::zeros(n, n), |acc, &k| acc + &infos[k])
}

/// Picks `n` of the candidates' information matrices (`infos`, all p x p), always including
/// `forced` (e.g. the upright posture), maximising `log det`. Fails if no choice determines all
/// unknowns.
pub fn d_optimal_subset(
    infos: &[DMatrix<f64>],
    n: usize,
    forced: &[usize],
) -> Result<DesignChoice, ComError> {
    if infos.is_empty() || n > infos.len() || forced.len() > n {
        return Err(ComError::TooFewPostures {
            need: n.max(forced.len()),
            got: infos.len(),
        });
    }
    let p = infos[0].nrows();
    // A ridge relative to the candidates' scale lets the greedy phase rank choices before the
    // information is full rank.
    let scale = infos
        .iter()
        .map(|m| m.trace())
        .fold(0.0, f64::max)
        .max(1e-300)
        / p as f64;
    let ridge = DMatrix::<f64>::identity(p, p) * (1e-9 * scale);
    let score = |set: &[usize]| log_det(&(sum(infos, set) + &ridge));
    let mut chosen: Vec<usize> = forced.to_vec();
    while chosen.len() < n {
        let best = (0..infos.len())
            .filter(|k| !chosen.contains(k))
            .map(|k| {
                let mut s = chosen.clone();
                s.push(k);
                (score(&s), k)
            })
            .max_by(|a, b| a.0.total_cmp(&b.0))
            .expect("n <= candidates");
        chosen.push(best.1);
    }
    // Exchange passes.
    let mut current = score(&chosen);
    loop {
        let mut improved = false;
        for slot in forced.len()..chosen.len() {
            for k in 0..infos.len() {
                if chosen.contains(&k) {
                    continue;
                }
                let mut s = chosen.clone();
                s[slot] = k;
                let v = score(&s);
                if v > current + 1e-9 {
                    chosen = s;
                    current = v;
                    improved = true;
                }
            }
        }
        if !improved {
            break;
        }
    }
    let info = sum(infos, &chosen);
    let ld = log_det(&info);
    let cond = condition_number(&info);
    if !ld.is_finite() || cond > 1e9 {
        return Err(ComError::Singular {
            what: "the unknowns with the best design of these candidates".into(),
            condition: cond,
        });
    }
    Ok(DesignChoice {
        chosen,
        log_det: ld,
        condition_number: cond,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rank1(v: &[f64]) -> DMatrix<f64> {
        let c = DMatrix::from_column_slice(v.len(), 1, v);
        &c * c.transpose()
    }

    #[test]
    fn picks_the_orthogonal_directions_over_repeats_of_one() {
        // Candidates: three times nearly the same direction, and x, y, z.
        let infos = vec![
            rank1(&[1.0, 0.0, 0.0]),
            rank1(&[0.9, 0.01, 0.0]),
            rank1(&[0.9, 0.0, 0.01]),
            rank1(&[0.0, 1.0, 0.0]),
            rank1(&[0.0, 0.0, 1.0]),
        ];
        let d = d_optimal_subset(&infos, 3, &[]).unwrap();
        let mut c = d.chosen.clone();
        c.sort();
        assert_eq!(c, vec![0, 3, 4]);
        assert!((d.condition_number - 1.0).abs() < 1e-9);
        // Two postures cannot determine three unknowns.
        assert!(d_optimal_subset(&infos, 2, &[]).is_err());
        // A forced candidate stays.
        let d = d_optimal_subset(&infos, 3, &[1]).unwrap();
        assert!(d.chosen.contains(&1));
    }

    #[test]
    fn matches_the_brute_force_optimum_on_a_small_case() {
        // diag(5, 1), 2 e_x, 2 e_y: the best pair is diag(5, 1) + 2 e_y (det 25).
        let infos = vec![
            DMatrix::from_row_slice(2, 2, &[5.0, 0.0, 0.0, 1.0]) * 0.5
                + DMatrix::from_row_slice(2, 2, &[2.5, 0.0, 0.0, 0.5]),
            rank1(&[2.0, 0.0]),
            rank1(&[0.0, 2.0]),
        ];
        let d = d_optimal_subset(&infos, 2, &[]).unwrap();
        let det = log_det(&(infos[d.chosen[0]].clone() + &infos[d.chosen[1]])).exp();
        let brute = [(0, 1), (0, 2), (1, 2)]
            .iter()
            .map(|&(a, b)| log_det(&(infos[a].clone() + &infos[b])).exp())
            .fold(0.0, f64::max);
        assert!((det - brute).abs() < 1e-9, "{det} vs {brute}");
    }
}
