//! The model file (`zmp-model/1`, TOML): which effects the plant has and their parameters.
//!
//! ```toml
//! format = "zmp-model/1"
//! name = "SILO2"
//!
//! [pendulum]            # a global effect: its parameters directly
//! a11 = 0.8293
//! # ...
//! [tracking_lowpass]    # per input axis; a flat table applies to both axes
//! omega_n = 30.0
//! zeta = 1.0
//! [uncertainty]         # per channel; values here are shared by the sub-tables
//! delta = 0.0
//! [uncertainty.G11]     # sub-tables name the instances: x/y for axis effects, G11..G22
//! k = 4.0
//! z = 1.0
//! p = 10.0
//! ```
//!
//! A table with sub-tables has exactly the instances it names, each with the table's own values
//! overlaid by its sub-table's. Besides effect tables, `format`, `name`, `description`, and the
//! tables `provenance` and `stderr` (standard errors, same layout as the effects) are allowed;
//! anything else is an error that names the file and the key.

use crate::effect::{lookup, Binding, BuildContext, Effect, EffectInfo, ParamSpec, REGISTRY};
use crate::EffectKind;
use std::fmt;
use std::fmt::Write as _;

pub const MODEL_FORMAT: &str = "zmp-model/1";

const META_KEYS: [&str; 5] = ["format", "name", "description", "provenance", "stderr"];

/// A model-file error: the file, the dotted key, and what is wrong.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ModelError {
    pub file: String,
    pub key: String,
    pub message: String,
}

impl fmt::Display for ModelError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.key.is_empty() {
            write!(f, "{}: {}", self.file, self.message)
        } else {
            write!(f, "{}: {}: {}", self.file, self.key, self.message)
        }
    }
}

impl std::error::Error for ModelError {}

/// One instance of an effect: where it acts and its parameter values in `info.params` order.
#[derive(Debug, Clone)]
pub struct EffectInstance {
    pub info: &'static EffectInfo,
    pub binding: Binding,
    pub values: Vec<f64>,
}

impl EffectInstance {
    /// Dotted key of this instance (`uncertainty.G11`, `pendulum`).
    pub fn key(&self) -> String {
        match self.binding.key() {
            Some(b) => format!("{}.{}", self.info.kind, b),
            None => self.info.kind.to_string(),
        }
    }

    pub fn value(&self, param: &str) -> Option<f64> {
        self.info.param_index(param).map(|i| self.values[i])
    }

    pub fn build(&self, ctx: &BuildContext) -> Box<dyn Effect> {
        (self.info.build)(ctx, &self.values)
    }
}

/// A parsed model: effects in canonical order, plus metadata kept verbatim.
#[derive(Debug, Clone)]
pub struct ModelSpec {
    pub name: Option<String>,
    pub description: Option<String>,
    pub effects: Vec<EffectInstance>,
    /// `provenance` and `stderr` tables, kept as they are.
    pub provenance: toml::Table,
    pub stderr: toml::Table,
}

/// A parameter of a model with its full dotted name (`uncertainty.G11.k`).
#[derive(Debug, Clone)]
pub struct ParamRef {
    pub key: String,
    pub spec: &'static ParamSpec,
    pub value: f64,
    pub effect: usize,
    pub index: usize,
}

fn err(file: &str, key: impl Into<String>, message: impl Into<String>) -> ModelError {
    ModelError {
        file: file.to_string(),
        key: key.into(),
        message: message.into(),
    }
}

fn as_number(v: &toml::Value) -> Option<f64> {
    match v {
        toml::Value::Float(f) => Some(*f),
        toml::Value::Integer(i) => Some(*i as f64),
        _ => None,
    }
}

impl ModelSpec {
    /// Parses a model file's text; `file` names it in errors.
    pub fn parse(text: &str, file: &str) -> Result<ModelSpec, ModelError> {
        let table: toml::Table = text.parse().map_err(|e: toml::de::Error| {
            let msg = e.message().to_string();
            let line = e
                .span()
                .map(|s| text[..s.start.min(text.len())].lines().count().max(1));
            match line {
                Some(l) => err(file, format!("line {l}"), format!("TOML syntax: {msg}")),
                None => err(file, "", format!("TOML syntax: {msg}")),
            }
        })?;
        Self::from_table(&table, file)
    }

    pub fn from_table(table: &toml::Table, file: &str) -> Result<ModelSpec, ModelError> {
        match table.get("format") {
            Some(toml::Value::String(s)) if s == MODEL_FORMAT => {}
            Some(v) => {
                return Err(err(
                    file,
                    "format",
                    format!("expected \"{MODEL_FORMAT}\", got {v}"),
                ))
            }
            None => {
                return Err(err(
                    file,
                    "format",
                    format!("missing; expected \"{MODEL_FORMAT}\""),
                ))
            }
        }
        let string = |key: &str| -> Result<Option<String>, ModelError> {
            match table.get(key) {
                None => Ok(None),
                Some(toml::Value::String(s)) => Ok(Some(s.clone())),
                Some(v) => Err(err(
                    file,
                    key,
                    format!("expected a string, got {}", v.type_str()),
                )),
            }
        };
        let subtable = |key: &str| -> Result<toml::Table, ModelError> {
            match table.get(key) {
                None => Ok(toml::Table::new()),
                Some(toml::Value::Table(t)) => Ok(t.clone()),
                Some(v) => Err(err(
                    file,
                    key,
                    format!("expected a table, got {}", v.type_str()),
                )),
            }
        };
        let mut spec = ModelSpec {
            name: string("name")?,
            description: string("description")?,
            effects: Vec::new(),
            provenance: subtable("provenance")?,
            stderr: subtable("stderr")?,
        };
        for (key, value) in table {
            if META_KEYS.contains(&key.as_str()) {
                continue;
            }
            let Some(info) = lookup(key) else {
                let known: Vec<&str> = REGISTRY.iter().map(|i| i.kind.name()).collect();
                return Err(err(
                    file,
                    key.as_str(),
                    format!("unknown effect (known: {})", known.join(", ")),
                ));
            };
            let toml::Value::Table(t) = value else {
                return Err(err(
                    file,
                    key.as_str(),
                    format!("expected a table of parameters, got {}", value.type_str()),
                ));
            };
            spec.effects.extend(parse_effect(info, t, file)?);
        }
        spec.sort();
        spec.validate(file)?;
        Ok(spec)
    }

    /// Canonical order: registry order, then binding order.
    pub fn sort(&mut self) {
        let rank = |e: &EffectInstance| {
            let r = REGISTRY
                .iter()
                .position(|i| std::ptr::eq(*i, e.info))
                .unwrap_or(usize::MAX);
            let b = crate::effect::Binding::all_for(e.info.site)
                .iter()
                .position(|b| *b == e.binding)
                .unwrap_or(0);
            (r, b)
        };
        self.effects.sort_by_key(rank);
    }

    /// Checks that the core effects are there once per binding, values are in bounds and
    /// pass their effect's own check.
    pub fn validate(&self, file: &str) -> Result<(), ModelError> {
        for info in REGISTRY.iter().filter(|i| i.core) {
            for b in crate::effect::Binding::all_for(info.site) {
                if self.get(info.kind, *b).is_none() {
                    let key = match b.key() {
                        Some(k) => format!("{}.{}", info.kind, k),
                        None => info.kind.to_string(),
                    };
                    return Err(err(
                        file,
                        key,
                        format!("missing: every model needs the {}", info.title),
                    ));
                }
            }
        }
        for (i, e) in self.effects.iter().enumerate() {
            if self.effects[..i]
                .iter()
                .any(|o| std::ptr::eq(o.info, e.info) && o.binding == e.binding)
            {
                return Err(err(file, e.key(), "given twice"));
            }
            if e.values.len() != e.info.params.len() {
                return Err(err(
                    file,
                    e.key(),
                    format!(
                        "{} values for {} parameters",
                        e.values.len(),
                        e.info.params.len()
                    ),
                ));
            }
            check_values(e.info, &e.values, file, || e.key())?;
        }
        Ok(())
    }

    pub fn get(&self, kind: EffectKind, binding: Binding) -> Option<&EffectInstance> {
        self.effects
            .iter()
            .find(|e| e.info.kind == kind && e.binding == binding)
    }

    pub fn get_mut(&mut self, kind: EffectKind, binding: Binding) -> Option<&mut EffectInstance> {
        self.effects
            .iter_mut()
            .find(|e| e.info.kind == kind && e.binding == binding)
    }

    pub fn has(&self, kind: EffectKind) -> bool {
        self.effects.iter().any(|e| e.info.kind == kind)
    }

    /// The value of `param` of effect `kind` at `binding`.
    pub fn value(&self, kind: EffectKind, binding: Binding, param: &str) -> Option<f64> {
        self.get(kind, binding).and_then(|e| e.value(param))
    }

    /// Sets a parameter; `false` if the effect instance or parameter does not exist.
    pub fn set_value(
        &mut self,
        kind: EffectKind,
        binding: Binding,
        param: &str,
        value: f64,
    ) -> bool {
        match self.get_mut(kind, binding) {
            Some(e) => match e.info.param_index(param) {
                Some(i) => {
                    e.values[i] = value;
                    true
                }
                None => false,
            },
            None => false,
        }
    }

    /// The pendulum's coefficients, when the model has its core pendulum.
    pub fn pendulum(&self) -> Option<crate::effects::pendulum::Pendulum> {
        self.get(EffectKind::Pendulum, Binding::Global)
            .map(|e| crate::effects::pendulum::Pendulum::from_values(&e.values))
    }

    /// Sets the pendulum's coefficients (adding the pendulum when the model has none).
    pub fn set_pendulum(&mut self, p: &crate::effects::pendulum::Pendulum) {
        self.insert(EffectInstance {
            info: EffectKind::Pendulum.info(),
            binding: Binding::Global,
            values: p.values().to_vec(),
        });
    }

    /// Adds (or replaces) an effect instance, keeping canonical order.
    /// Adds `instance` (replacing one of the same kind and place). Its values may leave out
    /// trailing optional parameters: they take their defaults.
    pub fn insert(&mut self, mut instance: EffectInstance) {
        let params = instance.info.params;
        while instance.values.len() < params.len() {
            match params[instance.values.len()].default {
                Some(d) => instance.values.push(d),
                None => break,
            }
        }
        self.effects
            .retain(|e| !(std::ptr::eq(e.info, instance.info) && e.binding == instance.binding));
        self.effects.push(instance);
        self.sort();
    }

    /// Removes every instance of `kind`, and its standard errors (a model written after an
    /// effect was taken out kept the effect's `stderr` table, held-out draw 1230010's
    /// `backlash-for-coulomb_friction` version a friction's).
    pub fn remove(&mut self, kind: EffectKind) {
        self.effects.retain(|e| e.info.kind != kind);
        self.stderr.remove(kind.name());
    }

    /// Every parameter of every effect instance, with its dotted name.
    pub fn parameters(&self) -> Vec<ParamRef> {
        let mut out = Vec::new();
        for (ei, e) in self.effects.iter().enumerate() {
            for (pi, p) in e.info.params.iter().enumerate() {
                out.push(ParamRef {
                    key: format!("{}.{}", e.key(), p.name),
                    spec: p,
                    value: e.values[pi],
                    effect: ei,
                    index: pi,
                });
            }
        }
        out
    }

    /// The model file text. Every parameter carries its unit and meaning as a comment.
    pub fn to_toml(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "format = \"{MODEL_FORMAT}\"");
        if let Some(n) = &self.name {
            let _ = writeln!(s, "name = {}", toml::Value::String(n.clone()));
        }
        if let Some(d) = &self.description {
            let _ = writeln!(s, "description = {}", toml::Value::String(d.clone()));
        }
        for info in REGISTRY.iter() {
            let inst: Vec<&EffectInstance> = self
                .effects
                .iter()
                .filter(|e| std::ptr::eq(e.info, *info))
                .collect();
            if inst.is_empty() {
                continue;
            }
            let all = crate::effect::Binding::all_for(info.site);
            let uniform =
                inst.len() == all.len() && inst.iter().all(|e| e.values == inst[0].values);
            let _ = writeln!(s, "\n# {}: {}", info.title, info.doc);
            if uniform {
                let _ = writeln!(s, "[{}]", info.kind);
                write_values(&mut s, info, &inst[0].values);
            } else {
                for e in inst {
                    let _ = writeln!(s, "[{}]", e.key());
                    write_values(&mut s, info, &e.values);
                }
            }
        }
        for (name, t) in [("provenance", &self.provenance), ("stderr", &self.stderr)] {
            if !t.is_empty() {
                let mut wrap = toml::Table::new();
                wrap.insert(name.to_string(), toml::Value::Table(t.clone()));
                let _ = write!(s, "\n{}", toml::to_string(&wrap).unwrap_or_default());
            }
        }
        s
    }
}

fn write_values(s: &mut String, info: &EffectInfo, values: &[f64]) {
    for (p, v) in info.params.iter().zip(values) {
        let _ = writeln!(s, "{} = {}  # {}: {}", p.name, fmt_float(*v), p.unit, p.doc);
    }
}

/// Shortest round-trip decimal that TOML reads as a float.
pub fn fmt_float(v: f64) -> String {
    let s = format!("{v:?}");
    if s.contains('.') || s.contains('e') || s.contains("inf") || s.contains("NaN") {
        s
    } else {
        format!("{s}.0")
    }
}

/// Checks an effect's values; `key` names the effect in an error (built only for one: plants
/// are built, and their specs validated, hundreds of thousands of times in a diagnosis).
fn check_values(
    info: &EffectInfo,
    values: &[f64],
    file: &str,
    key: impl Fn() -> String,
) -> Result<(), ModelError> {
    if let Some(validate) = info.validate {
        if let Err((i, msg)) = validate(values) {
            return Err(err(file, format!("{}.{}", key(), info.params[i].name), msg));
        }
    }
    for (p, v) in info.params.iter().zip(values) {
        if !v.is_finite() || *v < p.min || *v > p.max {
            return Err(err(
                file,
                format!("{}.{}", key(), p.name),
                format!(
                    "{v} is out of bounds [{}, {}] {} ({})",
                    p.min, p.max, p.unit, p.doc
                ),
            ));
        }
    }
    Ok(())
}

fn parse_values(
    info: &EffectInfo,
    base: &toml::Table,
    over: Option<&toml::Table>,
    file: &str,
    key: &str,
) -> Result<Vec<f64>, ModelError> {
    info.params
        .iter()
        .map(|p| {
            let v = over
                .and_then(|o| o.get(p.name))
                .or_else(|| base.get(p.name));
            match v {
                Some(v) => as_number(v).ok_or_else(|| {
                    err(
                        file,
                        format!("{key}.{}", p.name),
                        format!("expected a number ({}), got {}", p.unit, v.type_str()),
                    )
                }),
                None => p.default.ok_or_else(|| {
                    err(
                        file,
                        format!("{key}.{}", p.name),
                        format!("missing: {} ({})", p.doc, p.unit),
                    )
                }),
            }
        })
        .collect()
}

fn parse_effect(
    info: &'static EffectInfo,
    t: &toml::Table,
    file: &str,
) -> Result<Vec<EffectInstance>, ModelError> {
    let mut subs: Vec<(Binding, &toml::Table)> = Vec::new();
    for (k, v) in t {
        if info.param_index(k).is_some() {
            continue;
        }
        match (Binding::parse(info.site, k), v) {
            (Some(b), toml::Value::Table(st)) => {
                for sk in st.keys() {
                    if info.param_index(sk).is_none() {
                        return Err(unknown_param(
                            info,
                            file,
                            &format!("{}.{k}.{sk}", info.kind),
                        ));
                    }
                }
                subs.push((b, st));
            }
            (Some(_), v) => {
                return Err(err(
                    file,
                    format!("{}.{k}", info.kind),
                    format!("expected a table of parameters, got {}", v.type_str()),
                ))
            }
            (None, _) => return Err(unknown_param(info, file, &format!("{}.{k}", info.kind))),
        }
    }
    if subs.is_empty() {
        Binding::all_for(info.site)
            .iter()
            .map(|b| {
                let key = info.kind.to_string();
                Ok(EffectInstance {
                    info,
                    binding: *b,
                    values: parse_values(info, t, None, file, &key)?,
                })
            })
            .collect()
    } else {
        subs.into_iter()
            .map(|(b, st)| {
                let key = format!("{}.{}", info.kind, b);
                Ok(EffectInstance {
                    info,
                    binding: b,
                    values: parse_values(info, t, Some(st), file, &key)?,
                })
            })
            .collect()
    }
}

fn unknown_param(info: &EffectInfo, file: &str, key: &str) -> ModelError {
    let params: Vec<&str> = info.params.iter().map(|p| p.name).collect();
    let bindings: Vec<&str> = Binding::all_for(info.site)
        .iter()
        .filter_map(|b| b.key())
        .collect();
    let mut known = params.join(", ");
    if !bindings.is_empty() {
        known.push_str(&format!("; instances: {}", bindings.join(", ")));
    }
    err(
        file,
        key,
        format!("unknown parameter or instance (known: {known})"),
    )
}
