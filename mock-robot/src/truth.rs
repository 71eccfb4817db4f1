//! Ground-truth CSV log: one row per cycle with the true payload, true joint torques, external
//! torques and the active contact (onset, link, point, force), so detectors and estimators can
//! be scored against what really happened.
//!
//! Columns (SI units; joints 1..7; contact fields empty when no contact is active):
//! `t_s, cycle, fri_state, quality, payload_attached, payload_mass_kg, payload_com_x_m,
//! payload_com_y_m, payload_com_z_m, q1..q7 [rad], qd1..qd7 [rad/s], tau_j1..tau_j7 [Nm, true
//! link-side], tau_ext1..tau_ext7 [Nm, Σ Jᵀ F], tau_msr1..tau_msr7 [Nm, as reported],
//! sensor_bias1..sensor_bias7 [Nm], contact_id, contact_link, contact_onset_s,
//! contact_point_x_m..z (link frame), contact_base_x_m..z (base frame), contact_fx_n..fz (base)`.

use std::io::Write;

use fri::wire::Measurement;

use crate::simulation::Simulation;

/// Writes the ground-truth CSV.
#[derive(Debug)]
pub struct TruthLog<W: Write> {
    out: W,
}

impl<W: Write> TruthLog<W> {
    /// Starts a log on `out` and writes the header line.
    pub fn new(mut out: W) -> std::io::Result<Self> {
        let mut header = String::from(
            "t_s,cycle,fri_state,quality,payload_attached,payload_mass_kg,payload_com_x_m,payload_com_y_m,payload_com_z_m",
        );
        for name in [
            "q",
            "qd",
            "tau_j",
            "tau_ext",
            "tau_msr",
            "sensor_bias",
            "setpoint",
        ] {
            for j in 1..=7 {
                header.push_str(&format!(",{name}{j}"));
            }
        }
        header.push_str(",contact_id,contact_link,contact_onset_s,contact_point_x_m,contact_point_y_m,contact_point_z_m,contact_base_x_m,contact_base_y_m,contact_base_z_m,contact_fx_n,contact_fy_n,contact_fz_n\n");
        out.write_all(header.as_bytes())?;
        Ok(Self { out })
    }

    /// Appends the row of the current cycle (`msr` = the measurement just produced).
    pub fn record(&mut self, sim: &Simulation, msr: &Measurement) -> std::io::Result<()> {
        let o = &mut self.out;
        write!(
            o,
            "{:.6},{},{},{}",
            sim.time_s(),
            sim.cycles(),
            msr.interface.state.to_raw(),
            msr.interface.quality.to_raw()
        )?;
        match sim.true_payload() {
            Some(p) => {
                let c = p.com().unwrap_or_default();
                write!(o, ",1,{},{},{},{}", p.mass, c.x, c.y, c.z)?;
            }
            None => write!(o, ",0,0,0,0,0")?,
        }
        let bias = sim.sensor_bias();
        for v in [
            sim.q(),
            sim.qd(),
            sim.true_joint_torques(),
            sim.external_torques(),
        ] {
            for x in v.iter() {
                write!(o, ",{x}")?;
            }
        }
        for x in &msr.data.msr_jnt_trq {
            write!(o, ",{x}")?;
        }
        for x in bias.iter().chain(sim.commanded_setpoint().iter()) {
            write!(o, ",{x}")?;
        }
        match sim.contacts().iter().find(|c| c.active) {
            Some(c) => writeln!(
                o,
                ",{},{},{},{},{},{},{},{},{},{},{},{}",
                c.index,
                c.link,
                c.onset_s.unwrap_or(f64::NAN),
                c.point_link_m.x,
                c.point_link_m.y,
                c.point_link_m.z,
                c.point_base_m.x,
                c.point_base_m.y,
                c.point_base_m.z,
                c.force_n.x,
                c.force_n.y,
                c.force_n.z
            )?,
            None => o.write_all(b",,,,,,,,,,,,\n")?,
        }
        Ok(())
    }

    /// Flushes buffered rows.
    pub fn flush(&mut self) -> std::io::Result<()> {
        self.out.flush()
    }

    /// The writer, with everything written so far.
    pub fn into_inner(self) -> W {
        self.out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::SimulationConfig;
    use crate::contact::{ContactProfile, ContactSpec};

    #[test]
    fn rows_have_header_width_and_contact_columns() {
        let config = SimulationConfig {
            contacts: vec![ContactSpec {
                link: 6,
                point_m: [0.0, 0.05, 0.0],
                onset_s: 0.005,
                profile: ContactProfile::Ramp {
                    direction: [1.0, 0.0, 0.0],
                    rate_n_per_s: 1000.0,
                    max_force_n: 20.0,
                    duration_s: 0.05,
                },
            }],
            ..Default::default()
        };
        let mut sim = Simulation::new(config).unwrap();
        let mut log = TruthLog::new(Vec::new()).unwrap();
        for _ in 0..20 {
            let m = sim.step_cycle(None);
            log.record(&sim, &m).unwrap();
        }
        let text = String::from_utf8(log.out).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 21);
        let width = lines[0].split(',').count();
        assert_eq!(width, 9 + 49 + 12);
        assert!(lines.iter().all(|l| l.split(',').count() == width));
        assert!(lines[1].ends_with(",,,,,,,,,,,,"));
        let last: Vec<&str> = lines[20].split(',').collect();
        assert_eq!(last[width - 11], "6");
        let onset: f64 = last[width - 10].parse().unwrap();
        assert!((onset - 0.005).abs() < 3e-4, "onset {onset}");
        let fx: f64 = last[width - 3].parse().unwrap();
        assert!(fx > 5.0 && fx <= 20.0);
    }
}
