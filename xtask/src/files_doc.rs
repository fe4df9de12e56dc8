//! The rules of `docs/src/files-and-safety.md` that come from the code (the kinds of file and
//! how they are recognised, the size limits) are written there by the test below, so the page
//! cannot state a rule or a limit the code does not apply.

#[cfg(test)]
mod tests {
    use std::fmt::Write as _;
    use zmp_files::{limits, Kind};

    fn mib(bytes: u64) -> String {
        format!("{} MiB ({bytes} bytes)", bytes >> 20)
    }

    fn kinds() -> String {
        let mut s = String::from("| kind | recognised by |\n|---|---|\n");
        for k in Kind::ALL {
            let _ = writeln!(s, "| {} | {} |", k.describe(), k.rule());
        }
        s
    }

    fn limits_text() -> String {
        use zmp_campaign::{MAX_COLUMNS, MAX_MANIFEST_BYTES, MAX_RECORD_BYTES};
        format!(
            "| input | limit |\n|---|---|\n\
             | `campaign.toml` | {} |\n\
             | a record CSV | {} |\n\
             | a record's header | {MAX_COLUMNS} columns |\n\
             | a model file, a design, a README section's page | {} |\n\
             | the ledger | {} |\n\
             | `loop --time-limit` | {} s (7 days) |\n",
            mib(MAX_MANIFEST_BYTES),
            mib(MAX_RECORD_BYTES),
            mib(limits::MODEL_BYTES),
            mib(limits::LEDGER_BYTES),
            crate::loop_cmd::MAX_TIME_LIMIT.as_secs(),
        )
    }

    /// Writes (with `ZMP_UPDATE_DOCS=1`) or checks the page's section `tag`.
    fn section(tag: &str, text: &str) {
        let path = crate::env::repo_root().join("docs/src/files-and-safety.md");
        if let Err(e) = zmp_files::sections::check_or_update(&path, tag, text) {
            panic!("{e}");
        }
    }

    #[test]
    fn the_docs_quote_the_rules() {
        section("files-kinds", &kinds());
        section("files-limits", &limits_text());
    }
}
