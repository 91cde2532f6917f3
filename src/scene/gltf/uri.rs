//! The URI policy of glTF buffers and images: base64 `data:` URIs, and relative paths
//! (percent-decoded) that stay inside the glTF file's folder, read up to
//! [`MAX_REFERENCED_FILE_BYTES`]. Refused with one error naming the URI: `file:` URIs, any
//! other scheme (`http:` …; a Windows drive letter reads as one), absolute paths and
//! relative paths that climb out of the folder (`../`); from memory, any file at all.

use std::path::{Path, PathBuf};

/// Largest buffer or image file a glTF may reference.
pub const MAX_REFERENCED_FILE_BYTES: u64 = 4 << 30;

/// Bytes behind a URI: a base64 data URI, or a relative path under `base` (the glTF
/// file's folder; `None` when loading from memory) that the URI policy allows.
pub(super) fn read_uri(base: Option<&Path>, uri: &str) -> Result<Vec<u8>, String> {
    if uri.starts_with("data:") {
        // Data URIs never touch the file system; the crate's decoder is safe here.
        return gltf::buffer::Data::from_source(gltf::buffer::Source::Uri(uri), None)
            .map(|d| d.0)
            .map_err(|e| format!("bad data URI: {e}"));
    }
    let Some(base) = base else {
        return Err(format!(
            "refers to external file '{}', which cannot be loaded from memory",
            short(uri)
        ));
    };
    let relative = check_relative_uri(uri)?;
    let path = base.join(relative);
    crate::files::read_bounded(&path, MAX_REFERENCED_FILE_BYTES, "a glTF buffer or image").map_err(
        |e| match e {
            crate::files::FileError::Io { cause: source, .. }
                if source.kind() == std::io::ErrorKind::NotFound =>
            {
                format!("'{}' not found", path.display())
            }
            e => e.to_string(),
        },
    )
}

/// The relative path under the glTF file's folder that a URI names, `None` for a data URI
/// or one the URI policy refuses (its load reports it).
pub(super) fn relative_path(uri: &str) -> Option<PathBuf> {
    if uri.starts_with("data:") {
        return None;
    }
    check_relative_uri(uri).ok()
}

/// The relative path a non-data URI names, when the URI policy (module doc) allows it.
fn check_relative_uri(uri: &str) -> Result<PathBuf, String> {
    let refuse = |why: &str| {
        Err(format!(
            "URI '{}' is refused: {why}; glTF files may only reference files beside them (relative paths inside their folder) or data: URIs",
            short(uri)
        ))
    };
    if uri.starts_with("file:") {
        return refuse("file: URIs can name any file on the machine");
    }
    // A scheme is letters, digits, '+', '-', '.' before the first ':' (RFC 3986); a
    // Windows drive letter ("C:") lands here too and is absolute.
    if let Some((scheme, _)) = uri.split_once(':')
        && !scheme.is_empty()
        && scheme
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '+' | '-' | '.'))
    {
        return refuse(
            "only relative paths and data: URIs are read (no network, no other schemes)",
        );
    }
    let decoded = percent_decode(uri).ok_or("bad percent-encoding in URI")?;
    let path = Path::new(&decoded);
    if path.is_absolute() || decoded.starts_with('/') || decoded.starts_with('\\') {
        return refuse("absolute paths can name any file on the machine");
    }
    let mut depth = 0i32;
    for part in path.components() {
        match part {
            std::path::Component::ParentDir => depth -= 1,
            std::path::Component::Normal(_) => depth += 1,
            std::path::Component::CurDir => {}
            _ => return refuse("absolute paths can name any file on the machine"),
        }
        if depth < 0 {
            return refuse("the path leaves the glTF file's folder");
        }
    }
    Ok(path.to_path_buf())
}

/// `uri` shortened for messages (data URIs can be megabytes).
fn short(uri: &str) -> String {
    const MAX: usize = 80;
    match uri.char_indices().nth(MAX) {
        Some((i, _)) => format!("{}…", &uri[..i]),
        None => uri.to_string(),
    }
}

/// `name` as one segment of a URI path: every byte but RFC 3986's unreserved characters
/// percent-encoded (the inverse of [`percent_decode`]).
pub fn percent_encode(name: &str) -> String {
    let mut out = String::with_capacity(name.len());
    for &b in name.as_bytes() {
        if b.is_ascii_alphanumeric() || matches!(b, b'-' | b'.' | b'_' | b'~') {
            out.push(char::from(b));
        } else {
            out.push_str(&format!("%{b:02X}"));
        }
    }
    out
}

/// RFC 3986 percent-decoding into UTF-8, `None` when malformed.
fn percent_decode(s: &str) -> Option<String> {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = std::str::from_utf8(bytes.get(i + 1..i + 3)?).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}
