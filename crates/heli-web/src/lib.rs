//! What the workstation's web pages share: the operator's display (`heli-ground`) and the
//! simulator's truth and pilot page (`heli-sim`).
//!
//! What it is: a page's files served from the binary ([`Site`]: the page's own directory,
//! then the shared one), the shared files themselves (`web/`: the 3D instruments and the
//! style), and the gate every page and WebSocket is served through ([`gate`]: a key per
//! run, the Host and Origin checked, framing refused, the operator's and observer's roles).
//!
//! What it is not: a page. Each crate embeds its own HTML and scripts and serves them with
//! its own routes; nothing is fetched from elsewhere, at build or run time.

pub mod gate;

use axum::http::{StatusCode, Uri, header};
use axum::response::{IntoResponse, Response};
use include_dir::{Dir, include_dir};

/// The files every page may load: `view3d.js` (the 3D view of the helicopter, a module on
/// three.js: `three.module.min.js`, vendored with its licence `three.LICENSE.txt`; its world
/// in `field3d.js`, the helicopter's solids and shadow in `xcell3d.js`),
/// `instruments.js` (the attitude, the track, the plots, and the flat 3D drawing used where
/// WebGL is not to be had) and `style.css`; and `xcell60.json`, the helicopter's shape
/// ([`heli_types::shape::XCELL_60`], as the flight log carries it).
pub static SHARED: Dir<'_> = include_dir!("$CARGO_MANIFEST_DIR/web");

/// A page's files: its own directory, then [`SHARED`].
#[derive(Clone, Copy, Debug)]
pub struct Site {
    /// The page's own files.
    pub own: &'static Dir<'static>,
    /// What the page is, for a "not found" answer (`ground station`, `simulator view`).
    pub name: &'static str,
}

impl Site {
    /// The file at `uri`'s path (`/` is `index.html`), with its content type and no
    /// caching, or 404 naming what is missing.
    pub fn file(&self, uri: &Uri) -> Response {
        let path = uri.path().trim_start_matches('/');
        let path = if path.is_empty() { "index.html" } else { path };
        if path == SHAPE_FILE {
            return (
                [
                    (header::CONTENT_TYPE, "application/json"),
                    (header::CACHE_CONTROL, "no-cache"),
                ],
                shape_json(),
            )
                .into_response();
        }
        let Some(file) = self.own.get_file(path).or_else(|| SHARED.get_file(path)) else {
            return (
                StatusCode::NOT_FOUND,
                format!("no {path} on this {}", self.name),
            )
                .into_response();
        };
        (
            [
                (header::CONTENT_TYPE, content_type(path)),
                (header::CACHE_CONTROL, "no-cache"),
            ],
            file.contents(),
        )
            .into_response()
    }
}

/// The path under which every page finds the helicopter's shape.
pub const SHAPE_FILE: &str = "xcell60.json";

/// The X-Cell 60 as JSON: its parts (`{name, solid: {kind, ...}, center_frd_m, rgba,
/// group}`), the box that holds them (`bounds_frd_m`: least and most, m) and its rotor's
/// diameter (m), the size the views frame it by.
pub fn shape_json() -> String {
    use heli_types::shape;
    serde_json::json!({
        "parts": shape::XCELL_60,
        "bounds_frd_m": shape::bounds_frd_m(shape::XCELL_60),
        "rotor_diameter_m": 2.0 * shape::MAIN_ROTOR_RADIUS_M,
    })
    .to_string()
}

/// The content type of a file by its name.
pub fn content_type(path: &str) -> &'static str {
    match path.rsplit('.').next() {
        Some("html") => "text/html; charset=utf-8",
        Some("js") => "text/javascript; charset=utf-8",
        Some("css") => "text/css; charset=utf-8",
        Some("svg") => "image/svg+xml",
        Some("png") => "image/png",
        _ => "application/octet-stream",
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use axum::body::to_bytes;

    static NONE: Dir<'_> = include_dir!("$CARGO_MANIFEST_DIR/src");

    fn body(r: Response) -> (StatusCode, String, String) {
        let status = r.status();
        let kind = r
            .headers()
            .get(header::CONTENT_TYPE)
            .and_then(|v| v.to_str().ok())
            .unwrap_or("")
            .to_string();
        let rt = tokio::runtime::Builder::new_current_thread()
            .build()
            .unwrap();
        let bytes = rt.block_on(to_bytes(r.into_body(), 1 << 20)).unwrap();
        (status, kind, String::from_utf8_lossy(&bytes).into_owned())
    }

    #[test]
    fn a_page_gets_its_own_files_then_the_shared_ones_and_a_404_names_the_site() {
        let site = Site {
            own: &NONE,
            name: "test page",
        };
        let (status, kind, text) = body(site.file(&Uri::from_static("/lib.rs")));
        assert_eq!(
            (status, kind.as_str()),
            (StatusCode::OK, "application/octet-stream")
        );
        assert!(text.contains("What the workstation's web pages share"));
        let (status, kind, _) = body(site.file(&Uri::from_static("/instruments.js")));
        assert_eq!(
            (status, kind.as_str()),
            (StatusCode::OK, "text/javascript; charset=utf-8")
        );
        let (status, _, text) = body(site.file(&Uri::from_static("/")));
        assert_eq!(status, StatusCode::NOT_FOUND);
        assert_eq!(text, "no index.html on this test page");
        assert_eq!(content_type("a.css"), "text/css; charset=utf-8");
        let (status, kind, text) = body(site.file(&Uri::from_static("/xcell60.json")));
        assert_eq!(
            (status, kind.as_str()),
            (StatusCode::OK, "application/json")
        );
        let shape: serde_json::Value = serde_json::from_str(&text).unwrap();
        let parts = &shape["parts"];
        assert_eq!(
            parts.as_array().map(Vec::len),
            Some(heli_types::shape::XCELL_60.len())
        );
        assert_eq!(parts[0]["solid"]["kind"], "ellipsoid");
        assert_eq!(parts[2]["solid"]["axis"], "forward");
        assert_eq!(shape["rotor_diameter_m"], 1.55);
        assert_eq!(shape["bounds_frd_m"][1][2], 0.358);
        assert_eq!(content_type("a.html"), "text/html; charset=utf-8");
    }
}
