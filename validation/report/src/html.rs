//! What every HTML report shares: escaping of text and the style sheet.

/// `s` as HTML text: `&`, `<` and `>` escaped (attribute values are written in double quotes,
/// so `"` too).
pub fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The reports' style sheet (a `<style>` element): readable width, tables with lines, numbers
/// right and text left (class `l`), figures no wider than the page, cells unbroken (class
/// `nw`), figures side by side (`row`), notes (`note`), warnings (`warn`), verdicts (`v`,
/// `ok`, `bad`).
pub const STYLE: &str = "<style>body{font-family:sans-serif;max-width:1100px;margin:2em auto;\
padding:0 1em;}table{border-collapse:collapse;margin:1em 0;}td,th{border:1px solid #ccc;\
padding:3px 8px;text-align:right;vertical-align:top;}th{background:#eee;}.l{text-align:left;}\
.nw{white-space:nowrap;}.row{display:flex;flex-wrap:wrap;gap:0 1em;}\
svg,img{max-width:100%;height:auto;}.v{font-size:1.3em;}.ok{color:#070;}.bad,.warn{color:#a40;}\
.note{color:#555;}</style>";

#[cfg(test)]
mod tests {
    #[test]
    fn markup_is_escaped() {
        assert_eq!(
            super::esc("a < b && \"c\" > d"),
            "a &lt; b &amp;&amp; &quot;c&quot; &gt; d"
        );
    }
}
