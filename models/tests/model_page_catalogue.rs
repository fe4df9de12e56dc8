//! The book's model page (`docs/src/model.md`) documents every effect and every parameter of
//! the registry: a new effect or parameter without documentation fails here.

use zmp_models::REGISTRY;

#[test]
fn the_model_page_documents_every_effect_and_parameter() {
    let readme = include_str!("../../docs/src/model.md");
    let table_start = readme
        .find("## Effects")
        .expect("docs/src/model.md has an Effects section");
    let table = &readme[table_start..];
    let table = &table[..table.find("\n## ").unwrap_or(table.len())];
    for info in REGISTRY {
        let row = table
            .lines()
            .find(|l| l.starts_with(&format!("| `{}` |", info.kind)))
            .unwrap_or_else(|| panic!("docs/src/model.md effect table lacks `{}`", info.kind));
        for p in info.params {
            assert!(
                row.contains(&format!("`{}", p.name)) || row.contains(&format!(" {}", p.name)),
                "docs/src/model.md row of `{}` does not mention parameter `{}`",
                info.kind,
                p.name
            );
        }
    }
}
