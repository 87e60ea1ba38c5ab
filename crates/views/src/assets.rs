//! The dashboard's static assets, vendored in the crate (`crates/views/assets`) and
//! served by mtcal itself under `/static/`: the pages need no network.

/// The stylesheet.
pub const CSS: &str = include_str!("../assets/mtcal.css");
/// The script: job progress polling and the upload form (no build step, no library).
pub const JS: &str = include_str!("../assets/mtcal.js");

/// `/static/{name}?v={hash of the content}`: a new version is a new URL, so browsers may
/// cache each one for long.
pub fn href(name: &str) -> String {
    use std::hash::{Hash, Hasher};
    let mut h = std::hash::DefaultHasher::new();
    get(name).map(|(_, body)| body).unwrap_or("").hash(&mut h);
    format!("/static/{name}?v={:016x}", h.finish())
}

/// The asset at `name` (the path below `/static/`) with its content type.
pub fn get(name: &str) -> Option<(&'static str, &'static str)> {
    match name {
        "mtcal.css" => Some(("text/css; charset=utf-8", CSS)),
        "mtcal.js" => Some(("text/javascript; charset=utf-8", JS)),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn assets_are_served_by_name_only() {
        assert!(super::get("mtcal.css").unwrap().0.starts_with("text/css"));
        assert!(super::get("mtcal.js").unwrap().1.contains("data-job"));
        assert!(super::get("../Cargo.toml").is_none());
        assert!(super::href("mtcal.css").starts_with("/static/mtcal.css?v="));
        assert_eq!(super::href("mtcal.js"), super::href("mtcal.js"));
    }
}
