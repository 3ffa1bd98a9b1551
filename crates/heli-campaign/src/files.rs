//! A campaign's report written out: `report.json` and the outcome plots.

use std::path::{Path, PathBuf};

use crate::Report;
use crate::log_plot::ImageFormat;

/// Writes `report.json` and the outcome plots (SVG and PNG) into `dir`; returns what it
/// wrote.
pub fn write_report(report: &Report, dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    let context = |what: String| {
        move |e: std::io::Error| std::io::Error::new(e.kind(), format!("{what}: {e}"))
    };
    std::fs::create_dir_all(dir).map_err(context(format!("creating {}", dir.display())))?;
    let mut written = Vec::new();
    let path = dir.join("report.json");
    let json = serde_json::to_string_pretty(report).map_err(std::io::Error::other)? + "\n";
    std::fs::write(&path, json).map_err(context(format!("writing {}", path.display())))?;
    written.push(path);
    for (name, format) in [
        ("outcomes.svg", ImageFormat::Svg),
        ("outcomes.png", ImageFormat::Png),
    ] {
        let path = dir.join(name);
        crate::plot::render(report, format, &path).map_err(std::io::Error::other)?;
        written.push(path);
    }
    Ok(written)
}
