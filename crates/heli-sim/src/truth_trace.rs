//! The truth beside the estimate, as CSV (`heli sim --truth FILE`): at every control period
//! of a lockstep flight, where the simulated helicopter really is, how it is turned and how
//! fast it goes, next to what the flight software believes, with the attitude error between
//! them. The flight log holds only what the vehicle knew; this is what explains a campaign's
//! failure ("the estimate started 40° off in roll"), and it opens in any spreadsheet or
//! plotting tool.
//!
//! What it is not: a flight log (`heli sim --log`), which the vehicle writes too and which
//! replays; this file exists only in simulation, where there is a truth.

use std::fmt::Write as _;
use std::io::{self, BufWriter, Write};
use std::path::Path;

use crate::lockstep::Simulation;

/// How often a row is written (µs): the control period.
pub const PERIOD_US: u64 = 20_000;

/// The CSV's header: the truth (`true_*`), the estimate (`est_*`, empty before the estimate
/// runs and while the flight computer is browned out), the angle between the true and the
/// estimated attitude, the flight phase (`browned-out` while it has no power) and the
/// rotor's speed. SI units, named in each column.
pub const HEADER: &str = "t_s,phase,\
true_pos_n_m,true_pos_e_m,true_pos_d_m,true_vel_n_mps,true_vel_e_mps,true_vel_d_mps,\
true_roll_rad,true_pitch_rad,true_yaw_rad,\
est_pos_n_m,est_pos_e_m,est_pos_d_m,est_vel_n_mps,est_vel_e_mps,est_vel_d_mps,\
est_roll_rad,est_pitch_rad,est_yaw_rad,att_err_rad,rotor_rpm";

/// Writes the truth beside the estimate, one row per control period.
pub struct TruthTrace<W: Write> {
    out: W,
    next_us: u64,
    row: String,
}

impl TruthTrace<BufWriter<std::fs::File>> {
    /// A trace written to the file at `path` (created, or emptied).
    pub fn create(path: &Path) -> io::Result<Self> {
        Self::new(BufWriter::new(std::fs::File::create(path)?))
    }
}

impl<W: Write> TruthTrace<W> {
    /// A trace written to `out`; the header goes out at once.
    pub fn new(mut out: W) -> io::Result<Self> {
        writeln!(out, "{HEADER}")?;
        Ok(Self {
            out,
            next_us: 0,
            row: String::new(),
        })
    }

    /// Writes a row if a control period has passed since the last one.
    pub fn observe(&mut self, sim: &Simulation) -> io::Result<()> {
        if sim.now_us() < self.next_us {
            return Ok(());
        }
        self.next_us = sim.now_us() - sim.now_us() % PERIOD_US + PERIOD_US;
        let truth = sim.truth_frame();
        let true_att = sim.helicopter().state.att;
        let core = sim.core();
        let row = &mut self.row;
        row.clear();
        // Browned out, no flight process runs: the phase and the estimate left in memory are
        // nobody's.
        let running = !sim.browned_out();
        let phase = if running {
            core.phase().name()
        } else {
            "browned-out"
        };
        // Writing into a String cannot fail.
        let _ = write!(row, "{:.3},{phase}", truth.t_s);
        for x in truth
            .pos_ned_m
            .iter()
            .chain(&truth.vel_ned_mps)
            .chain(&truth.euler_rad)
        {
            let _ = write!(row, ",{x:.5}");
        }
        match core.navigator().state().filter(|_| running) {
            Some(est) => {
                let (roll, pitch, yaw) = est.att.euler_angles();
                for x in est
                    .pos_ned_m
                    .iter()
                    .chain(est.vel_ned_mps.iter())
                    .chain(&[roll, pitch, yaw])
                {
                    let _ = write!(row, ",{x:.5}");
                }
                let _ = write!(row, ",{:.5}", est.att.angle_to(&true_att));
            }
            // The nine `est_*` columns and `att_err_rad`, empty.
            None => row.push_str(",,,,,,,,,,"),
        }
        let _ = write!(row, ",{:.0}", truth.rotor_rpm);
        writeln!(self.out, "{row}")
    }

    /// Flushes what is written and hands the writer back.
    pub fn finish(mut self) -> io::Result<W> {
        self.out.flush()?;
        Ok(self.out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rows(text: &str) -> Vec<Vec<String>> {
        text.lines()
            .skip(1)
            .map(|l| l.split(',').map(str::to_string).collect())
            .collect()
    }

    #[test]
    fn a_row_per_control_period_with_the_estimate_beside_the_truth_once_it_runs() {
        let mut scenario = heli_scenario::hover();
        scenario.duration_s = 120.0;
        let mut sim = Simulation::new(scenario).unwrap_or_else(|e| panic!("{e}"));
        let mut trace = TruthTrace::new(Vec::new()).unwrap_or_else(|e| panic!("{e}"));
        while sim.advance(120_000_000) {
            trace.observe(&sim).unwrap_or_else(|e| panic!("{e}"));
        }
        let text = String::from_utf8(trace.finish().unwrap_or_else(|e| panic!("{e}")))
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(text.lines().next(), Some(HEADER));
        let columns = HEADER.split(',').count();
        let rows = rows(&text);
        // 120 s at 50 Hz, the first at 0.
        assert!((5999..=6001).contains(&rows.len()), "{} rows", rows.len());
        assert!(rows.iter().all(|r| r.len() == columns), "ragged rows");
        let col = |name: &str| {
            HEADER
                .split(',')
                .position(|c| c == name)
                .unwrap_or_else(|| panic!("{name}"))
        };
        let t = |r: &Vec<String>| r[col("t_s")].parse::<f64>().unwrap_or(f64::NAN);
        assert!((t(&rows[1]) - t(&rows[0]) - 0.02).abs() < 1e-9);
        // Calibrating on the skids: no estimate yet, the truth on the ground.
        let first = &rows[0];
        assert_eq!(first[col("est_roll_rad")], "");
        assert_eq!(first[col("phase")], "calibrating");
        // At 115 s the hover's estimate runs and agrees with the truth within a few degrees;
        // the helicopter is up.
        let late = rows
            .iter()
            .find(|r| t(r) >= 115.0)
            .unwrap_or_else(|| panic!("no row at 115 s"));
        let num = |name: &str| late[col(name)].parse::<f64>().unwrap_or(f64::NAN);
        assert!(num("true_pos_d_m") < -3.0, "{late:?}");
        assert!(num("att_err_rad") < 0.05, "{late:?}");
        assert!(
            (num("est_pos_d_m") - num("true_pos_d_m")).abs() < 2.0,
            "{late:?}"
        );
        assert!(num("rotor_rpm") > 1400.0, "{late:?}");
    }
}
