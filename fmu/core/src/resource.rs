//! The FMI 2.0 `fmuResourceLocation`: a `file:` URI of the FMU's `resources` directory.

use std::path::PathBuf;

fn percent_decode(s: &str) -> Result<String, String> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let hex = s
                .get(i + 1..i + 3)
                .and_then(|h| u8::from_str_radix(h, 16).ok())
                .ok_or_else(|| format!("bad percent escape in {s:?}"))?;
            out.push(hex);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out).map_err(|_| format!("{s:?} is not UTF-8 after percent-decoding"))
}

/// The directory a resource location names. Accepts `file:///abs`, `file://localhost/abs`,
/// `file:/abs` and, leniently, a plain absolute path.
pub fn resource_dir(location: &str) -> Result<PathBuf, String> {
    let path = if let Some(rest) = location.strip_prefix("file://") {
        if let Some(p) = rest.strip_prefix("localhost/") {
            format!("/{p}")
        } else if rest.starts_with('/') {
            rest.to_string()
        } else {
            return Err(format!(
                "resource location {location:?}: only local file URIs are supported"
            ));
        }
    } else if let Some(rest) = location.strip_prefix("file:") {
        if !rest.starts_with('/') {
            return Err(format!(
                "resource location {location:?} is not an absolute file URI"
            ));
        }
        rest.to_string()
    } else if location.starts_with('/') {
        return Ok(PathBuf::from(location));
    } else {
        return Err(format!("resource location {location:?} is not a file: URI"));
    };
    Ok(PathBuf::from(percent_decode(&path)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uris() {
        assert_eq!(
            resource_dir("file:///tmp/a%20b/resources").unwrap(),
            PathBuf::from("/tmp/a b/resources")
        );
        assert_eq!(
            resource_dir("file:/tmp/r/").unwrap(),
            PathBuf::from("/tmp/r/")
        );
        assert_eq!(
            resource_dir("file://localhost/tmp/r").unwrap(),
            PathBuf::from("/tmp/r")
        );
        assert_eq!(resource_dir("/tmp/r").unwrap(), PathBuf::from("/tmp/r"));
        assert!(resource_dir("http://x/r").is_err());
        assert!(resource_dir("file://server/r").is_err());
        assert!(resource_dir("file:///tmp/%zz").is_err());
    }
}
