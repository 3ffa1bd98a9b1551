//! Tests of the plots.

use super::*;
use serde_json::json;

fn log(messages: Vec<(&str, u64, Value)>) -> LogContents {
    LogContents {
        messages: messages
            .into_iter()
            .map(|(topic, t_us, value)| LoggedMessage {
                topic: topic.to_string(),
                t_us,
                sequence: 0,
                value,
            })
            .collect(),
        ..Default::default()
    }
}

fn state_log(n: u64) -> LogContents {
    let mut messages = Vec::new();
    for i in 0..n {
        let t = i as f64 * 0.02;
        messages.push((
            "state",
            i * 20_000,
            json!({
                "phase": "hold",
                "roll_rad": (t).sin(),
                "pos_ned_m": [t, 2.0 * t, -10.0],
                "armed": i % 2 == 0,
            }),
        ));
    }
    messages.push(("events", 1_000_000, json!({"text": "calibration done"})));
    log(messages)
}

#[test]
fn default_panels_group_vectors_and_skip_text() {
    let (panels, left_out) = panels(&state_log(100), "state", &[], Window::default()).unwrap();
    assert_eq!(left_out, 0);
    let titles: Vec<&str> = panels.iter().map(|p| p.title.as_str()).collect();
    assert_eq!(titles, ["armed", "pos_ned_m", "roll_rad"]);
    let pos = &panels[1];
    assert_eq!(pos.series.len(), 3);
    assert_eq!(pos.series[1].name, "pos_ned_m[1]");
    assert_eq!(pos.series[1].values[50], 2.0 * 50.0 * 0.02);
    assert_eq!(panels[0].series[0].values[..3], [1.0, 0.0, 1.0]);
}

#[test]
fn named_fields_select_components_and_unknown_fields_are_refused() {
    let log = state_log(10);
    let fields = vec!["pos_ned_m[2]".to_string(), "roll_rad".to_string()];
    let (panels, _) = panels(&log, "state", &fields, Window::default()).unwrap();
    assert_eq!(panels.len(), 2);
    assert_eq!(panels[0].series.len(), 1);
    assert_eq!(panels[0].series[0].values[0], -10.0);
    // `pos` is a prefix of a name but not a field.
    let err = panels_err(&log, &["pos"]);
    let PlotError::UnknownField { available, .. } = err else {
        panic!("expected an unknown field");
    };
    assert!(available.contains(&"roll_rad".to_string()));
    assert!(matches!(
        panels_err(&log, &["phase"]),
        PlotError::UnknownField { .. }
    ));
}

fn panels_err(log: &LogContents, fields: &[&str]) -> PlotError {
    let fields: Vec<String> = fields.iter().map(|f| f.to_string()).collect();
    panels(log, "state", &fields, Window::default()).unwrap_err()
}

#[test]
fn window_limits_samples_and_events() {
    let log = state_log(500);
    let window = Window {
        from_s: Some(2.0),
        to_s: Some(4.0),
    };
    let (roll, _) = panels(&log, "state", &["roll_rad".into()], window).unwrap();
    let t = &roll[0].series[0].t_s;
    assert!(t.iter().all(|&t| (2.0..=4.0).contains(&t)));
    assert_eq!(t.len(), 101);
    assert!(events(&log, window).is_empty());
    assert_eq!(events(&log, Window::default()).len(), 1);
    let empty = Window {
        from_s: Some(100.0),
        to_s: None,
    };
    assert!(matches!(
        panels(&log, "state", &[], empty),
        Err(PlotError::NoMessages { .. })
    ));
    assert!(matches!(
        panels(&log, "nothing", &[], Window::default()),
        Err(PlotError::NoMessages { .. })
    ));
}

#[test]
fn text_only_channel_has_nothing_to_plot() {
    let log = state_log(3);
    assert!(matches!(
        panels(&log, "events", &[], Window::default()),
        Err(PlotError::NothingNumeric { .. })
    ));
}

#[test]
fn thinning_keeps_a_one_sample_spike_and_the_bounds() {
    let n = 50_000;
    let mut series = Series {
        name: "x".into(),
        t_s: (0..n).map(|i| i as f64).collect(),
        values: vec![0.0; n],
    };
    series.values[31_337] = 7.0;
    series.values[0] = -1.0;
    let thin = thin(&series);
    assert!(thin.values.len() <= MAX_POINTS_PER_SERIES);
    assert!(thin.values.contains(&7.0));
    assert!(thin.values.contains(&-1.0));
    assert!(thin.t_s.contains(&31_337.0));
    assert!(thin.t_s.windows(2).all(|w| w[0] < w[1]), "time order kept");
}

#[test]
fn renders_svg_and_png_with_every_panel() {
    let log = state_log(2000);
    let (panels, _) = panels(&log, "state", &[], Window::default()).unwrap();
    let marks = events(&log, Window::default());
    let dir = std::env::temp_dir().join(format!("heli-plot-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();

    let svg_path = dir.join("state.svg");
    render(&panels, &marks, "state", ImageFormat::Svg, &svg_path).unwrap();
    let svg = std::fs::read_to_string(&svg_path).unwrap();
    assert!(svg.starts_with("<svg"));
    for title in ["armed", "pos_ned_m", "roll_rad", "pos_ned_m[2]", "t (s)"] {
        assert!(svg.contains(title), "{title} missing from the SVG");
    }
    // 5 traces drawn as polylines, plus the event mark in each of the 3 panels.
    assert!(svg.matches("<polyline").count() >= 5 + 3);
    // The one event is numbered once, in the marks' colour.
    assert_eq!(svg.matches(r##"fill="#C81E1E""##).count(), 1, "{svg:.0}");

    let png_path = dir.join("state.png");
    render(&panels, &marks, "state", ImageFormat::Png, &png_path).unwrap();
    let png = std::fs::read(&png_path).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    let height = u32::from_be_bytes([png[20], png[21], png[22], png[23]]);
    assert_eq!(height, 3 * PANEL_HEIGHT_PX + 40);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn diverged_and_tiny_values_still_give_a_finite_axis() {
    for values in [
        vec![-1e308, 1e308],
        vec![f64::MAX, f64::MAX],
        vec![1e-12, 3e-12],
        vec![0.0, 0.0],
        vec![],
    ] {
        let panel = Panel {
            title: "x".into(),
            series: vec![Series {
                name: "x".into(),
                t_s: (0..values.len()).map(|i| i as f64).collect(),
                values: values.clone(),
            }],
        };
        let (lo, hi) = value_span(&panel);
        assert!(
            lo.is_finite() && hi.is_finite() && lo < hi,
            "{values:?}: {lo} {hi}"
        );
    }
    let (lo, hi) = padded([1e-12, 3e-12].into_iter());
    assert_eq!(
        (lo, hi),
        (1e-12, 3e-12),
        "a small signal keeps its own scale"
    );
    // Drawing a diverged trace finishes.
    let panel = Panel {
        title: "diverged".into(),
        series: vec![Series {
            name: "x".into(),
            t_s: vec![0.0, 1.0, 2.0],
            values: vec![0.0, -1e308, 1e308],
        }],
    };
    let path = std::env::temp_dir().join(format!("heli-plot-big-{}.svg", std::process::id()));
    render(&[panel], &[], "big", ImageFormat::Svg, &path).unwrap();
    std::fs::remove_file(&path).ok();
}

#[test]
fn format_follows_the_extension() {
    assert_eq!(
        ImageFormat::from_path(Path::new("a/b.SVG")),
        Some(ImageFormat::Svg)
    );
    assert_eq!(
        ImageFormat::from_path(Path::new("b.png")),
        Some(ImageFormat::Png)
    );
    assert_eq!(ImageFormat::from_path(Path::new("b.jpg")), None);
    assert_eq!(ImageFormat::from_path(Path::new("b")), None);
}
