//! `modelDescription.xml` of the FMI 2.0 co-simulation FMUs, written from the variable table.

use crate::units::base_unit;
use crate::vars::{Causality, FmiVersion, Kind, VarTable};
use std::fmt::Write as _;

/// Escapes text for an XML attribute value.
pub fn escape(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&apos;"),
            '\n' | '\r' | '\t' => o.push(' '),
            c if (c as u32) < 0x20 => {}
            c => o.push(c),
        }
    }
    o
}

/// Shortest round-trip text of a double, as `xs:double` reads it.
pub fn real(v: f64) -> String {
    format!("{v:?}")
}

/// The model description of `table`'s FMU with GUID `guid`; `model_name` names the model file.
pub fn model_description(table: &VarTable, guid: &str, model_name: &str) -> String {
    let kind = table.kind;
    let id = kind.model_identifier(FmiVersion::V2);
    let mut s = String::new();
    let _ = writeln!(s, r#"<?xml version="1.0" encoding="UTF-8"?>"#);
    let _ = writeln!(
        s,
        r#"<fmiModelDescription fmiVersion="2.0" modelName="{}" guid="{}" description="{}" author="zmp-toolkit" version="{}" generationTool="zmp-fmu {}" variableNamingConvention="structured" numberOfEventIndicators="0">"#,
        escape(&format!("{id} ({model_name})")),
        escape(guid),
        escape(kind.description()),
        env!("CARGO_PKG_VERSION"),
        crate::guid::binary_version(),
    );
    // The plant uses first input derivatives (fmi2SetRealInputDerivatives, order 1).
    let interpolates = table.interpolates_inputs();
    let _ = writeln!(
        s,
        r#"  <CoSimulation modelIdentifier="{id}" needsExecutionTool="false" canHandleVariableCommunicationStepSize="true" canInterpolateInputs="{interpolates}" maxOutputDerivativeOrder="0" canRunAsynchronuously="false" canBeInstantiatedOnlyOncePerProcess="false" canNotUseMemoryManagementFunctions="true" canGetAndSetFMUstate="false" canSerializeFMUstate="false" providesDirectionalDerivative="false"/>"#
    );
    let vars: Vec<&crate::vars::Var> = table.vars.iter().collect();
    let _ = writeln!(s, "  <UnitDefinitions>");
    for u in table.units() {
        match base_unit(u) {
            Some(b) => {
                let attrs: String = b
                    .exponents()
                    .iter()
                    .map(|(n, e)| format!(r#" {n}="{e}""#))
                    .collect();
                let _ = writeln!(
                    s,
                    r#"    <Unit name="{}"><BaseUnit{attrs}/></Unit>"#,
                    escape(u)
                );
            }
            None => {
                let _ = writeln!(s, r#"    <Unit name="{}"/>"#, escape(u));
            }
        }
    }
    let _ = writeln!(s, "  </UnitDefinitions>");
    let _ = writeln!(s, "  <LogCategories>");
    for (name, doc) in LOG_CATEGORIES {
        let _ = writeln!(
            s,
            r#"    <Category name="{name}" description="{}"/>"#,
            escape(doc)
        );
    }
    let _ = writeln!(s, "  </LogCategories>");
    let (stop, step) = kind.default_experiment();
    let _ = writeln!(
        s,
        r#"  <DefaultExperiment startTime="0.0" stopTime="{}" stepSize="{}"/>"#,
        real(stop),
        real(step)
    );
    let _ = writeln!(s, "  <ModelVariables>");
    for (i, v) in vars.iter().enumerate() {
        let _ = writeln!(s, "    <!-- index {} -->", i + 1);
        let _ = writeln!(
            s,
            r#"    <ScalarVariable name="{}" valueReference="{}" description="{}" causality="{}" variability="{}">"#,
            escape(&v.name),
            v.vr,
            escape(&v.description),
            v.causality.as_str(),
            v.variability.as_str()
        );
        let mut real_attrs = format!(r#" unit="{}""#, escape(v.unit));
        if v.has_min() {
            let _ = write!(real_attrs, r#" min="{}""#, real(v.min));
        }
        if v.has_max() {
            let _ = write!(real_attrs, r#" max="{}""#, real(v.max));
        }
        if v.causality != Causality::Output {
            let _ = write!(real_attrs, r#" start="{}""#, real(v.start));
        }
        let _ = writeln!(s, "      <Real{real_attrs}/>");
        let _ = writeln!(s, "    </ScalarVariable>");
    }
    let _ = writeln!(s, "  </ModelVariables>");
    let _ = writeln!(s, "  <ModelStructure>");
    let outputs: Vec<usize> = (0..vars.len())
        .filter(|&i| vars[i].causality == Causality::Output)
        .collect();
    let inputs: Vec<String> = (0..vars.len())
        .filter(|&i| vars[i].causality == Causality::Input)
        .map(|i| (i + 1).to_string())
        .collect();
    let deps = if table.direct_feedthrough() {
        inputs.join(" ")
    } else {
        String::new()
    };
    let _ = writeln!(s, "    <Outputs>");
    for &i in &outputs {
        let _ = writeln!(
            s,
            r#"      <Unknown index="{}" dependencies="{deps}"/>"#,
            i + 1
        );
    }
    let _ = writeln!(s, "    </Outputs>");
    let _ = writeln!(s, "    <InitialUnknowns>");
    for &i in &outputs {
        let _ = writeln!(s, r#"      <Unknown index="{}"/>"#, i + 1);
    }
    let _ = writeln!(s, "    </InitialUnknowns>");
    let _ = writeln!(s, "  </ModelStructure>");
    let _ = writeln!(s, "</fmiModelDescription>");
    s
}

/// Log categories of the FMUs (FMI 2.0 standard names).
pub const LOG_CATEGORIES: [(&str, &str); 3] = [
    (
        "logStatusError",
        "errors: invalid arguments, calls out of order, rejected values (always logged)",
    ),
    ("logStatusWarning", "warnings"),
    ("logAll", "every call (with loggingOn)"),
];

/// Documentation page shipped in the FMU's `documentation/index.html`.
pub fn documentation(table: &VarTable, model_name: &str) -> String {
    let kind: Kind = table.kind;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>{}</title></head><body>",
        escape(kind.model_identifier(FmiVersion::V2))
    );
    let _ = writeln!(
        s,
        "<h1>{} &mdash; {}</h1><p>{}</p>",
        escape(kind.model_identifier(FmiVersion::V2)),
        escape(model_name),
        escape(kind.description())
    );
    let _ = writeln!(s, "<p>Stepping: {}</p>", escape(crate::STEPPING_DOC));
    let _ = writeln!(
        s,
        "<table border=\"1\"><tr><th>vr</th><th>name</th><th>causality</th><th>unit</th><th>start</th><th>description</th></tr>"
    );
    for v in &table.vars {
        let _ = writeln!(
            s,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            v.vr,
            escape(&v.name),
            v.causality.as_str(),
            escape(v.unit),
            real(v.start),
            escape(&v.description)
        );
    }
    let _ = writeln!(s, "</table></body></html>");
    s
}
