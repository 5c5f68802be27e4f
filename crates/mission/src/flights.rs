//! One mission per flight: a plan split by `--max-flight-time` is flown
//! as several missions, each from home and back on its own battery.

use std::path::{Path, PathBuf};

use vp_scene::plan::{Flight, Plan};

use crate::error::{MissionError, Result};
use crate::export::{export_files, export_text, DjiOptions, ExportFormat};
use crate::items::MissionOptions;

/// One exported file: where it goes (none: standard output or a string)
/// and its bytes.
#[derive(Debug, Clone, PartialEq)]
pub struct ExportedFlight {
    /// Where it is written; `None` when there is no output file.
    pub path: Option<PathBuf>,
    /// The file's content.
    pub bytes: Vec<u8>,
}

/// The missions of `plan`'s flights in `format`, each flight's files named
/// by [`flight_path`] (a Litchi mission split at 99 waypoints numbers its
/// parts within that): the one entry `vpctl mission export` and Python's
/// `export` share. Without `out` only the text formats of a one-flight plan
/// can be returned (to print).
pub fn export_flights(
    plan: &Plan,
    format: ExportFormat,
    opts: &MissionOptions,
    dji: &DjiOptions,
    out: Option<&Path>,
) -> Result<Vec<ExportedFlight>> {
    let flights = flight_plans(plan);
    let n = flights.len();
    let Some(out) = out else {
        if n > 1 {
            return Err(MissionError::InvalidInput(format!(
                "the plan is split into {n} flights: give --out FILE and each flight is written \
                 to its own numbered file (FILE-1, FILE-2, ...)"
            )));
        }
        return Ok(vec![ExportedFlight {
            path: None,
            bytes: export_text(plan, format, opts)?.into_bytes(),
        }]);
    };
    let mut files = Vec::new();
    for (i, p) in flights.iter().enumerate() {
        let path = flight_path(out, i + 1, n);
        let these = export_files(p, format, opts, dji, &path).map_err(|e| match e {
            MissionError::InvalidInput(m) if n > 1 => {
                MissionError::InvalidInput(format!("flight {}: {m}", i + 1))
            }
            other => other,
        })?;
        files.extend(these.into_iter().map(|(path, bytes)| ExportedFlight {
            path: Some(path),
            bytes,
        }));
    }
    Ok(files)
}

/// Writes every exported file that has a path, all or none: existing
/// files are refused before anything is written (unless `force`), and a
/// failed write removes the files written before it.
pub fn write_flights(files: &[ExportedFlight], force: bool) -> Result<()> {
    let files: Vec<(&PathBuf, &Vec<u8>)> = files
        .iter()
        .filter_map(|f| f.path.as_ref().map(|p| (p, &f.bytes)))
        .collect();
    for (p, _) in &files {
        vp_scene::fsio::check_overwrite(p, force)?;
    }
    for (i, (p, bytes)) in files.iter().enumerate() {
        if let Err(e) = vp_scene::fsio::write_file_atomic(p, bytes) {
            for (done, _) in &files[..i] {
                let _ = std::fs::remove_file(done);
            }
            return Err(e.into());
        }
    }
    Ok(())
}

/// The plan of each of `plan`'s flights, in order: the flight's waypoints
/// (renumbered from 0) with the rest of the plan as it is. A plan without
/// recorded flights is one flight.
pub fn flight_plans(plan: &Plan) -> Vec<Plan> {
    if plan.flights.len() <= 1 {
        return vec![plan.clone()];
    }
    plan.flights
        .iter()
        .map(|f| {
            let first = f.waypoints.first().copied().unwrap_or(0);
            let mut p = plan.clone();
            p.waypoints = f
                .waypoints
                .iter()
                .filter_map(|&i| plan.waypoints.get(i).cloned())
                .collect();
            p.unbridged = plan
                .unbridged
                .iter()
                .filter(|i| f.waypoints.contains(i))
                .map(|i| i - first)
                .collect();
            p.flights = vec![Flight {
                waypoints: (0..p.waypoints.len()).collect(),
                ..f.clone()
            }];
            p
        })
        .collect()
}

/// The file of flight `i` (1-based) of `n` for output `out`: `out` itself
/// for one flight, else `<stem>-<i>.<ext>` beside it (`m.plan` ->
/// `m-1.plan`, `m-2.plan`, ...).
pub fn flight_path(out: &Path, i: usize, n: usize) -> PathBuf {
    if n <= 1 {
        return out.to_path_buf();
    }
    let stem = out.file_stem().map(|s| s.to_string_lossy().into_owned());
    let name = match (stem, out.extension()) {
        (Some(s), Some(e)) => format!("{s}-{i}.{}", e.to_string_lossy()),
        (Some(s), None) => format!("{s}-{i}"),
        (None, _) => format!("mission-{i}"),
    };
    out.with_file_name(name)
}

/// The plan of flight `n` (1-based) of `plan`, for an upload: a plan of
/// several flights needs the one to fly named.
pub fn one_flight(plan: &Plan, n: Option<usize>) -> Result<Plan> {
    let mut flights = flight_plans(plan);
    let count = flights.len();
    match n {
        None if count == 1 => Ok(flights.remove(0)),
        None => Err(MissionError::InvalidInput(format!(
            "the plan is split into {count} flights (one battery each): upload one at a time \
             with --flight 1 .. --flight {count}"
        ))),
        Some(k) if (1..=count).contains(&k) => Ok(flights.remove(k - 1)),
        Some(k) => Err(MissionError::InvalidInput(format!(
            "--flight {k}: the plan has {count} flight(s), numbered from 1"
        ))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use vp_scene::plan::{PlannedView, Role};

    fn plan_of(n: usize, cuts: &[usize]) -> Plan {
        let mut p = Plan::new(None);
        p.waypoints = (0..n)
            .map(|i| PlannedView {
                position: [i as f64, 0.0, 10.0],
                yaw_deg: 0.0,
                pitch_deg: -90.0,
                roll_deg: 0.0,
                role: Role::Grid,
                triplet_id: None,
                expected_gain: None,
                angle_bin_deg: None,
            })
            .collect();
        let mut start = 0;
        for &end in cuts.iter().chain([&n]) {
            p.flights.push(Flight {
                waypoints: (start..end).collect(),
                distance_m: 1.0,
                duration_s: 1.0,
                from_home: true,
            });
            start = end;
        }
        p.unbridged = vec![1, 4];
        p
    }

    #[test]
    fn every_waypoint_goes_to_exactly_one_flight_in_order() {
        let p = plan_of(7, &[3, 5]);
        let f = flight_plans(&p);
        assert_eq!(f.len(), 3);
        let xs: Vec<f64> = f
            .iter()
            .flat_map(|q| q.waypoints.iter().map(|w| w.position[0]))
            .collect();
        assert_eq!(xs, (0..7).map(|i| i as f64).collect::<Vec<_>>());
        assert_eq!(f[0].unbridged, vec![1]);
        assert_eq!(f[1].unbridged, vec![1]);
        for q in &f {
            q.validate().unwrap();
        }
        assert!(one_flight(&p, None)
            .unwrap_err()
            .to_string()
            .contains("--flight 3"));
        assert_eq!(one_flight(&p, Some(2)).unwrap().waypoints.len(), 2);
        assert!(one_flight(&p, Some(4)).is_err());
    }

    #[test]
    fn files_are_numbered_only_when_there_are_several() {
        let out = Path::new("dir/m.plan");
        assert_eq!(flight_path(out, 1, 1), PathBuf::from("dir/m.plan"));
        assert_eq!(flight_path(out, 2, 3), PathBuf::from("dir/m-2.plan"));
    }
}
