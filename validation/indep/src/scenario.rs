//! Scenarios: which hidden effects a drawn robot carries.

use crate::robot::Effect;
use rand::Rng;
use std::fmt;
use std::str::FromStr;

/// Which hidden effects `draw` gives a robot.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Scenario {
    /// The seed's model only (acceleration saturation in its ordinary range, no hidden effect).
    Clean,
    /// One, two or three distinct, compatible catalogue effects.
    Catalogue(Vec<Effect>),
    /// One effect outside the catalogue, possibly with one catalogue effect.
    Outside {
        /// The out-of-catalogue effect.
        effect: Effect,
        /// An optional catalogue effect drawn with it.
        with: Option<Effect>,
    },
    /// A scenario drawn from the seed: clean 2/12, one catalogue effect 4/12, two 2/12, three
    /// 1/12, one outside effect 2/12, one outside plus one catalogue effect 1/12; effects
    /// uniformly among the compatible ones.
    Random,
}

impl Scenario {
    /// The hidden effects, in drawing order (the outside effect first).
    pub fn effects(&self) -> Vec<Effect> {
        match self {
            Scenario::Clean | Scenario::Random => Vec::new(),
            Scenario::Catalogue(v) => v.clone(),
            Scenario::Outside { effect, with } => std::iter::once(*effect).chain(*with).collect(),
        }
    }

    /// Checks the scenario's effects: catalogue lists of 1-3 distinct compatible catalogue
    /// effects, an outside effect outside the catalogue and a compatible companion inside it.
    pub fn validate(&self) -> Result<(), String> {
        let effects = self.effects();
        for (k, a) in effects.iter().enumerate() {
            for b in &effects[k + 1..] {
                if a.conflicts_with(*b) {
                    return Err(format!(
                        "{a} and {b} cannot be drawn together (same element or repeated)"
                    ));
                }
            }
        }
        match self {
            Scenario::Catalogue(v) => {
                if v.is_empty() || v.len() > 3 {
                    return Err(format!(
                        "a catalogue scenario has 1 to 3 effects, got {}",
                        v.len()
                    ));
                }
                if let Some(e) = v.iter().find(|e| !e.in_catalogue()) {
                    return Err(format!("{e} is outside the catalogue: use outside:{e}"));
                }
            }
            Scenario::Outside { effect, with } => {
                if effect.in_catalogue() {
                    return Err(format!(
                        "{effect} is a catalogue effect: use single:{effect}"
                    ));
                }
                if let Some(w) = with {
                    if !w.in_catalogue() {
                        return Err(format!("the companion of an outside effect must be a catalogue effect, got {w}"));
                    }
                }
            }
            Scenario::Clean | Scenario::Random => {}
        }
        Ok(())
    }

    /// Resolves `Random` with the given generator; other scenarios are returned unchanged.
    pub fn resolve(&self, rng: &mut impl Rng) -> Scenario {
        if *self != Scenario::Random {
            return self.clone();
        }
        let pick = |rng: &mut dyn rand::RngCore, pool: &[Effect], taken: &[Effect]| -> Effect {
            let free: Vec<Effect> = pool
                .iter()
                .copied()
                .filter(|e| taken.iter().all(|t| !t.conflicts_with(*e)))
                .collect();
            free[rng.gen_range(0..free.len())]
        };
        let roll = rng.gen_range(0..12);
        match roll {
            0..=1 => Scenario::Clean,
            2..=8 => {
                let n = match roll {
                    2..=5 => 1,
                    6..=7 => 2,
                    _ => 3,
                };
                let mut v = Vec::new();
                for _ in 0..n {
                    let e = pick(rng, &Effect::CATALOGUE, &v);
                    v.push(e);
                }
                Scenario::Catalogue(v)
            }
            _ => {
                let effect = pick(rng, &Effect::OUTSIDE, &[]);
                let with = (roll == 11).then(|| pick(rng, &Effect::CATALOGUE, &[effect]));
                Scenario::Outside { effect, with }
            }
        }
    }
}

impl fmt::Display for Scenario {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let join = |v: &[Effect]| v.iter().map(|e| e.name()).collect::<Vec<_>>().join(",");
        match self {
            Scenario::Clean => write!(f, "clean"),
            Scenario::Random => write!(f, "random"),
            Scenario::Catalogue(v) => {
                let kind = ["single", "pair", "triple"]
                    .get(v.len().wrapping_sub(1))
                    .unwrap_or(&"catalogue");
                write!(f, "{kind}:{}", join(v))
            }
            Scenario::Outside { effect, with: None } => write!(f, "outside:{effect}"),
            Scenario::Outside {
                effect,
                with: Some(w),
            } => write!(f, "outside:{effect},{w}"),
        }
    }
}

impl FromStr for Scenario {
    type Err = String;

    /// `clean`, `random`, `single:E`, `pair:E1,E2`, `triple:E1,E2,E3`, `outside:E` or
    /// `outside:E,C` (E outside the catalogue, C a catalogue effect).
    fn from_str(s: &str) -> Result<Self, String> {
        let s = s.trim();
        let parse_list = |list: &str| -> Result<Vec<Effect>, String> {
            list.split(',')
                .map(|n| {
                    let n = n.trim();
                    Effect::from_name(n).ok_or_else(|| {
                        let names: Vec<&str> = Effect::all().map(|e| e.name()).collect();
                        format!("unknown effect `{n}`; known: {}", names.join(", "))
                    })
                })
                .collect()
        };
        let scenario = match s.split_once(':') {
            None if s == "clean" => Scenario::Clean,
            None if s == "random" => Scenario::Random,
            Some((kind, list)) => {
                let want = match kind {
                    "single" => Some(1),
                    "pair" => Some(2),
                    "triple" => Some(3),
                    "outside" => None,
                    _ => return Err(format!("unknown scenario kind `{kind}` in `{s}`")),
                };
                let v = parse_list(list)?;
                match want {
                    Some(n) if v.len() != n => {
                        return Err(format!("`{kind}` takes {n} effect(s), got {} in `{s}`", v.len()))
                    }
                    Some(_) => Scenario::Catalogue(v),
                    None => match v.as_slice() {
                        [e] => Scenario::Outside { effect: *e, with: None },
                        [e, c] => Scenario::Outside { effect: *e, with: Some(*c) },
                        _ => return Err(format!("`outside` takes 1 or 2 effects, got {} in `{s}`", v.len())),
                    },
                }
            }
            None => {
                return Err(format!(
                    "unknown scenario `{s}`: use clean, random, single:E, pair:E1,E2, triple:E1,E2,E3, outside:E[,C]"
                ))
            }
        };
        scenario.validate()?;
        Ok(scenario)
    }
}
