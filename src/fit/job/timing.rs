//! Wall and CPU times of fits and sweeps ([`Timing`]), written under `data/timing/`, never under
//! `fits/`.

use serde::{Deserialize, Serialize};

use super::outcome::SweepOutcome;
use crate::error::Result;
use crate::fit::error::FitError;
use crate::fit::source::{FittedOn, Source};

/// Timings of a fit or a sweep: the sidecar `<data-dir>/timing/<fits folder>/sweep-timing.json`
/// (or `<fit file stem>-timing.json` for one fit). Wall and CPU times depend on the machine,
/// its load and the thread count, so they never go into files under `fits/`, which must be
/// byte-identical for identical inputs; `data/` is not committed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Timing {
    pub tool: String,
    pub tool_version: String,
    /// The fit or sweep file these times belong to (`fits/<name>/sweep.json`, …).
    pub fits_file: String,
    /// Content hash of the fitted data's source (as in the fit file's `source`).
    pub source_content_hash: String,
    /// Points the solver saw (metrics are always measured on all points).
    pub fitted_points: usize,
    /// Rayon worker threads.
    pub threads: usize,
    /// 1-, 5- and 15-minute load averages when the run ended (`/proc/loadavg`; None elsewhere).
    pub load_average: Option<[f64; 3]>,
    /// Wall time of the whole job: every fit, and measuring each on all points.
    pub wall_seconds: f64,
    /// CPU time (user + system, all threads) the process spent in the job (`/proc/self/stat`;
    /// None elsewhere). Less sensitive to other processes than the wall time.
    pub cpu_seconds: Option<f64>,
    /// Wall time of each fit's solve, in the order of the sweep's rows.
    pub fits: Vec<FitTime>,
}

/// Wall time of one fit's solve.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitTime {
    /// The fit's file name as a single fit (`rational-4-mu_sqrt-minimax.json`): with
    /// `n_coefficients` it identifies the row of `sweep.json`.
    pub name: String,
    pub n_coefficients: usize,
    pub seconds: f64,
}

/// A running job's clock: wall time and process CPU time since [`Stopwatch::start`].
#[derive(Clone, Copy, Debug)]
pub struct Stopwatch {
    wall: std::time::Instant,
    cpu: Option<f64>,
}

impl Stopwatch {
    pub fn start() -> Stopwatch {
        Stopwatch {
            wall: std::time::Instant::now(),
            cpu: process_cpu_seconds(),
        }
    }

    pub fn wall_seconds(&self) -> f64 {
        self.wall.elapsed().as_secs_f64()
    }

    pub fn cpu_seconds(&self) -> Option<f64> {
        Some(process_cpu_seconds()? - self.cpu?)
    }
}

/// Clock ticks per second of `/proc/self/stat` (Linux's USER_HZ, 100 on every architecture's ABI).
const USER_HZ: f64 = 100.0;

/// User + system CPU time of this process (all threads), from `/proc/self/stat` fields 14–15.
pub fn process_cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // the command name (field 2) is in parentheses and may contain spaces: skip past it
    let rest = &stat[stat.rfind(')')? + 1..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    // rest starts at field 3 (state): utime is field 14, stime field 15
    let utime: f64 = f.get(11)?.parse().ok()?;
    let stime: f64 = f.get(12)?.parse().ok()?;
    Some((utime + stime) / USER_HZ)
}

/// The 1-, 5- and 15-minute load averages from `/proc/loadavg`.
pub fn load_average() -> Option<[f64; 3]> {
    let text = std::fs::read_to_string("/proc/loadavg").ok()?;
    let v: Vec<f64> = text
        .split_whitespace()
        .take(3)
        .map(|x| x.parse().ok())
        .collect::<Option<_>>()?;
    Some([*v.first()?, *v.get(1)?, *v.get(2)?])
}

impl Timing {
    /// The timing record of a job measured by `clock`, for the file `fits_file`.
    pub fn new(
        fits_file: &str,
        source: &Source,
        fitted_on: &FittedOn,
        clock: &Stopwatch,
        fits: Vec<FitTime>,
    ) -> Timing {
        Timing {
            tool: "furnace".into(),
            tool_version: crate::VERSION.into(),
            fits_file: fits_file.into(),
            source_content_hash: source.content_hash.clone(),
            fitted_points: fitted_on.points,
            threads: rayon::current_num_threads(),
            load_average: load_average(),
            wall_seconds: clock.wall_seconds(),
            cpu_seconds: clock.cpu_seconds(),
            fits,
        }
    }

    /// Pretty JSON with a final newline.
    pub fn to_json(&self) -> Result<String> {
        Ok(format!(
            "{}\n",
            serde_json::to_string_pretty(self).map_err(FitError::from)?
        ))
    }
}

impl SweepOutcome {
    /// Every fit's solve time, in row order.
    pub fn fit_times(&self) -> Vec<FitTime> {
        self.rows
            .iter()
            .zip(&self.fit_seconds)
            .map(|(r, &seconds)| FitTime {
                name: r.name.clone(),
                n_coefficients: r.n_coefficients,
                seconds,
            })
            .collect()
    }
}
