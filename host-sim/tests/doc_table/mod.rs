//! A generated table in a doc page, shared by the tests that measure one: the table between
//! `<!-- MARKER:start -->` and `<!-- MARKER:end -->` in `docs/DOC` is rewritten with
//! `THERMORPH_WRITE_DOCS` set, and otherwise must equal what the test measured.

/// Check (or with `THERMORPH_WRITE_DOCS`, rewrite) `docs/{doc}`'s table `marker` against
/// `table`; a stale table fails, naming the command `regenerate` that rewrites it.
pub fn write_or_check(doc: &str, marker: &str, table: &str, regenerate: &str) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../docs")
        .join(doc);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("docs/{doc}: {e}"));
    let (start, end) = (
        format!("<!-- {marker}:start -->\n"),
        format!("<!-- {marker}:end -->"),
    );
    let a = text.find(&start).expect("start marker") + start.len();
    let b = text.find(&end).expect("end marker");
    if std::env::var_os("THERMORPH_WRITE_DOCS").is_some() {
        let new = format!("{}{table}{}", &text[..a], &text[b..]);
        std::fs::write(&path, new).unwrap();
    } else {
        assert_eq!(
            &text[a..b],
            table,
            "docs/{doc}'s {marker} table is stale: {regenerate}"
        );
    }
}
