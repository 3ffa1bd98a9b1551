//! `heli log`: what a flight log holds, a channel as CSV, a replay through a fresh flight
//! computer, and plots.

use std::process::ExitCode;

use anyhow::{Context, Result, bail};

use super::{LogAction, replay_cmd, write_stdout};

/// Runs the log command `action` asks for.
pub(crate) fn log(action: LogAction) -> Result<ExitCode> {
    let read = |file: &std::path::Path| -> Result<heli_log::LogContents> {
        let bytes = std::fs::read(file).with_context(|| format!("reading {}", file.display()))?;
        let contents = heli_log::read(&bytes);
        if let Some(stop) = &contents.stopped
            && stop.kind == heli_log::StopKind::NotMcap
        {
            bail!("{} is {stop}", file.display());
        }
        Ok(contents)
    };
    match action {
        LogAction::Replay { file } => return replay_cmd::replay(&file, &read(&file)?),
        LogAction::Info { file } => {
            let contents = read(&file)?;
            print_log_info(&file, &contents)?;
        }
        LogAction::Export {
            file,
            channel,
            out,
            partial,
        } => {
            let contents = read(&file)?;
            if let Some(stop) = &contents.stopped {
                let what = match stop.kind {
                    heli_log::StopKind::Truncated => "cut off",
                    _ => "damaged",
                };
                if !partial {
                    bail!(
                        "{} is {what}: {stop}; `--partial` exports the {} messages before it",
                        file.display(),
                        contents.messages.len()
                    );
                }
                eprintln!(
                    "heli log export: {} is {what} ({stop}): exporting the messages before it",
                    file.display()
                );
            }
            let csv = heli_log::to_csv(&contents, &channel);
            if csv.is_empty() {
                bail!(
                    "no messages on channel '{channel}' in {}; its channels: {}",
                    file.display(),
                    contents.counts().into_keys().collect::<Vec<_>>().join(", ")
                );
            }
            match out {
                Some(path) => std::fs::write(&path, csv)
                    .with_context(|| format!("writing {}", path.display()))?,
                None => write_stdout(&csv)?,
            }
        }
        LogAction::Plot {
            file,
            channel,
            fields,
            from,
            to,
            out,
        } => {
            use heli_campaign::log_plot as plot;
            if let (Some(from_s), Some(to_s)) = (from, to)
                && from_s > to_s
            {
                bail!("--from {from_s} is after --to {to_s}: the window would be empty");
            }
            let out = out.unwrap_or_else(|| {
                let stem = file.file_stem().and_then(|s| s.to_str()).unwrap_or("log");
                let name: String = channel
                    .chars()
                    .map(|c| {
                        if c.is_alphanumeric() || c == '-' {
                            c
                        } else {
                            '_'
                        }
                    })
                    .collect();
                file.with_file_name(format!("{stem}_{name}.svg"))
            });
            let format = plot::ImageFormat::from_path(&out)
                .ok_or_else(|| plot::PlotError::UnknownFormat(out.display().to_string()))?;
            let contents = read(&file)?;
            let window = plot::Window {
                from_s: from,
                to_s: to,
            };
            let (panels, left_out) = plot::panels(&contents, &channel, &fields, window)
                .with_context(|| format!("plotting {}", file.display()))?;
            let marks = plot::events(&contents, window);
            let title = format!("{} - {channel}", file.display());
            plot::render(&panels, &marks, &title, format, &out)?;
            println!("wrote {} ({} panels)", out.display(), panels.len());
            // The event texts begin with their time.
            for (i, (_, text)) in marks.iter().enumerate() {
                println!("  {:>3}  {text}", i + 1);
            }
            if left_out > 0 {
                println!(
                    "  {left_out} more fields not drawn (at most {} panels per plot): name fewer with --field",
                    plot::MAX_PANELS
                );
            }
            if let Some(why) = &contents.stopped {
                println!("  reading the log stopped early ({why}); plotted what was read");
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// Most faults `heli log info` lists one by one.
const FAULTS_LISTED: usize = 20;

/// `heli log info`: channels with their counts, rates, gaps and schemas, the metadata, the
/// warnings and worse, and whether the file is whole. A log with no message, or a corrupt
/// one, is an error (after what could be read is shown).
fn print_log_info(file: &std::path::Path, contents: &heli_log::LogContents) -> Result<()> {
    use heli_log::StopKind;
    if contents.messages.is_empty() {
        let why = contents
            .stopped
            .as_ref()
            .map_or(String::new(), |s| format!(" ({s})"));
        bail!("{} holds no messages{why}", file.display());
    }
    println!("{}", file.display());
    if let Some((first, last)) = contents.span_us() {
        println!(
            "  time     {:.3} s to {:.3} s",
            first as f64 * 1e-6,
            last as f64 * 1e-6
        );
    }
    let channels = heli_log::stats::channels(contents);
    // The channels' column as wide as the longest name (`foxglove/scene`).
    let w = channels
        .iter()
        .map(|c| c.topic.chars().count())
        .max()
        .unwrap_or(0)
        .max("channel".len());
    println!(
        "  {:<w$} {:>6} messages {:>10}  {:<22}  sequence",
        "channel", "", "rate", "largest interval"
    );
    for c in channels {
        let rate = c.rate_hz.map_or("-".to_string(), |hz| {
            if hz >= 1.0 {
                format!("{hz:.1} Hz")
            } else {
                format!("{hz:.3} Hz")
            }
        });
        let interval = format!(
            "{:.3} s before {:.2} s",
            c.largest_interval_us as f64 * 1e-6,
            c.largest_interval_end_us as f64 * 1e-6
        );
        let sequence = match (c.sequence_gaps, c.sequence_breaks) {
            (0, 0) => "no gaps".to_string(),
            (gaps, 0) => format!("{gaps} gaps, {} missing", c.missing),
            (gaps, breaks) => format!("{gaps} gaps, {} missing, {breaks} restarts", c.missing),
        };
        println!(
            "  {:<w$} {:>6} messages {:>10}  {interval:<22}  {sequence}  [{}]",
            c.topic,
            c.messages,
            rate,
            c.schema.as_deref().unwrap_or("no schema")
        );
    }
    for m in &contents.metadata {
        println!("  metadata '{}'", m.name);
        for (key, value) in &m.entries {
            let lines = value.lines().count();
            if lines > 1 {
                println!("    {key:<26} ({lines} lines)");
            } else {
                println!("    {key:<26} {value}");
            }
        }
    }
    let faults = heli_log::stats::faults(contents);
    if faults.is_empty() {
        println!("  faults   none (no event at level warning or worse)");
    } else {
        let n = faults.len();
        println!(
            "  faults   {n} event{} at level warning or worse",
            if n == 1 { "" } else { "s" }
        );
        for f in faults.iter().take(FAULTS_LISTED) {
            println!("    {:<8} {}", f.level.name(), f.text);
        }
        if faults.len() > FAULTS_LISTED {
            println!("    ... and {} more", faults.len() - FAULTS_LISTED);
        }
    }
    if contents.bad_messages > 0 {
        println!("  {} messages could not be decoded", contents.bad_messages);
    }
    match &contents.stopped {
        None if contents.closed => println!("  complete: closed by its writer"),
        None => println!(
            "  complete up to its last flush, not closed by its writer (crash, kill or power loss)"
        ),
        Some(stop) if stop.kind == StopKind::Truncated => {
            println!("  cut off: read up to the last whole chunk; {stop}")
        }
        Some(stop) => bail!(
            "{} is damaged: {stop}; the messages before it are listed above",
            file.display()
        ),
    }
    Ok(())
}
