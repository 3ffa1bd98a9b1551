//! `heli model`: the helicopter model alone: trim in level flight, the linearised hover
//! modes and the rotor-speed response, on the embedded X-Cell 60 or an airframe file.

use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use heli_model::analysis;
use heli_model::params::Airframe;

use super::{ModelAnalysis, ModelArgs};

/// Runs the analysis `args` asks for.
pub(crate) fn model(args: ModelArgs) -> Result<ExitCode> {
    let airframe = match &args.airframe {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("reading {}", path.display()))?;
            let airframe: Airframe = toml::from_str(&text)
                .with_context(|| format!("invalid airframe file {}", path.display()))?;
            heli_scenario::validate::airframe(&airframe)
                .map_err(|e| anyhow::anyhow!("airframe file {}: {e}", path.display()))?;
            airframe
        }
        None => Airframe::default(),
    };
    match args.analysis {
        ModelAnalysis::Trim { speed } => {
            if !speed.is_finite() || !(0.0..=25.0).contains(&speed) {
                bail!("--speed must be between 0 and 25 m/s (the model's envelope), not {speed}");
            }
            let t = analysis::trim(&airframe, speed).context("the trim did not converge")?;
            if args.json {
                println!("{}", serde_json::to_string_pretty(&t)?);
            } else {
                println!(
                    "trim at {:.1} m/s ({} iterations, residual {:.1e})",
                    t.speed_mps, t.iterations, t.residual
                );
                println!("  collective        {:8.3} deg", t.collective_deg);
                println!("  lateral cyclic    {:8.4} rad", t.lat_cyclic_rad);
                println!("  longitudinal cyc. {:8.4} rad", t.lon_cyclic_rad);
                println!("  tail pitch cmd    {:8.4} rad", t.tail_pitch_cmd_rad);
                println!(
                    "  roll / pitch      {:8.2} / {:.2} deg",
                    t.roll_deg, t.pitch_deg
                );
                println!(
                    "  flapping a1 / b1  {:8.3} / {:.3} deg",
                    t.flap_lon_deg, t.flap_lat_deg
                );
                println!("  thrust            {:8.2} N", t.thrust_n);
                println!("  main-rotor torque {:8.3} N m", t.mr_torque_nm);
                println!(
                    "  shaft power       {:8.1} W (throttle {:.3})",
                    t.power_w, t.throttle
                );
            }
        }
        ModelAnalysis::Modes => {
            let m = analysis::hover_modes(&airframe).context("the hover trim did not converge")?;
            if args.json {
                println!("{}", serde_json::to_string_pretty(&m)?);
            } else {
                println!("rotor-fuselage modes at hover");
                println!(
                    "  roll  (p, b1)  wn {:6.2} rad/s  zeta {:.3}",
                    m.roll.natural_frequency_rps, m.roll.damping
                );
                println!(
                    "  pitch (q, a1)  wn {:6.2} rad/s  zeta {:.3}",
                    m.pitch.natural_frequency_rps, m.pitch.damping
                );
                println!("full linearisation, eigenvalues (re, im):");
                for [re, im] in &m.full_eigenvalues {
                    println!("  {re:10.4} {im:+10.4}i");
                }
            }
        }
        ModelAnalysis::GovernorStep { step } => {
            if !step.is_finite() || step == 0.0 || step.abs() > 400.0 {
                bail!("--step must be a non-zero number of rpm up to 400, not {step}");
            }
            let g = analysis::governor_step(&airframe, step)
                .context("the hover trim did not converge")?;
            if args.json {
                println!("{}", serde_json::to_string_pretty(&g)?);
            } else {
                println!("governor step of {:.0} rpm at hover", g.step_rpm);
                println!(
                    "  poles: wn {:.3} rad/s, zeta {:.3}",
                    g.natural_frequency_rps, g.damping
                );
                println!(
                    "  response: overshoot {:.1} %, first peak at {:.2} s",
                    100.0 * g.overshoot,
                    g.peak_time_s
                );
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}
