//! The console's page and its libraries, embedded in the binary (`include_bytes!`): no files
//! to install, no Node build step. `assets/console/` holds them; `vendor/` the libraries as
//! fetched from the npm registry, with their licences (assets/console/vendor/README.md).

/// One embedded file: its name under `/assets/`, its content type, its bytes.
#[derive(Debug, Clone, Copy)]
pub struct Asset {
    /// The name it is served under.
    pub name: &'static str,
    /// Its `Content-Type`.
    pub content_type: &'static str,
    /// Its bytes.
    pub bytes: &'static [u8],
}

macro_rules! asset {
    ($name:literal, $type:literal) => {
        Asset {
            name: $name,
            content_type: $type,
            bytes: include_bytes!(concat!("../../../assets/console/", $name)),
        }
    };
}

/// The page.
pub const INDEX: Asset = asset!("index.html", "text/html; charset=utf-8");

/// Everything under `/assets/`.
pub const ASSETS: &[Asset] = &[
    asset!("app.js", "text/javascript; charset=utf-8"),
    asset!("style.css", "text/css; charset=utf-8"),
    asset!(
        "vendor/htm-preact-standalone.module.js",
        "text/javascript; charset=utf-8"
    ),
    asset!("vendor/uPlot.iife.min.js", "text/javascript; charset=utf-8"),
    asset!("vendor/uPlot.min.css", "text/css; charset=utf-8"),
    asset!("vendor/LICENSE.htm", "text/plain; charset=utf-8"),
    asset!("vendor/LICENSE.preact", "text/plain; charset=utf-8"),
    asset!("vendor/LICENSE.uplot", "text/plain; charset=utf-8"),
];

/// The asset called `name`.
#[must_use]
pub(super) fn find(name: &str) -> Option<&'static Asset> {
    ASSETS.iter().find(|a| a.name == name)
}

/// What a browser loads for the page: the page and every script and style sheet (not the
/// licence files), in bytes gzipped at level 9 each.
#[must_use]
pub fn page_files() -> Vec<&'static Asset> {
    std::iter::once(&INDEX)
        .chain(ASSETS.iter().filter(|a| !a.name.contains("LICENSE")))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_page_loads_only_what_is_embedded() {
        let page = std::str::from_utf8(INDEX.bytes).unwrap();
        for needed in [
            "/assets/app.js",
            "/assets/style.css",
            "/assets/vendor/uPlot.iife.min.js",
        ] {
            assert!(page.contains(needed), "{needed}");
        }
        let app = std::str::from_utf8(find("app.js").unwrap().bytes).unwrap();
        assert!(app.contains("/assets/vendor/htm-preact-standalone.module.js"));
        assert!(find("nope.js").is_none());
    }

    #[test]
    fn the_page_weighs_at_most_100_kb_even_uncompressed() {
        // The goal is 100 KB gzipped; served as is, the page and everything it loads stay
        // under it uncompressed (docs/BENCHMARKS.md gives the gzipped figure).
        let bytes: usize = page_files().iter().map(|a| a.bytes.len()).sum();
        assert!(bytes <= 100 * 1024, "{bytes} bytes");
    }
}
