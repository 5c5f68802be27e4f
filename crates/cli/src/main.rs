//! `vpctl`: plan UAV image acquisition for dense multi-view stereo.
//!
//! The binary is thin: it parses arguments, calls a library crate and maps
//! errors to exit codes (2 for bad usage or bad input, 1 for failures, 0 on a
//! closed pipe).

use std::io::{self, Write};
use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod cmd;
mod progress;

/// Plan UAV image acquisition for dense multi-view stereo (MVS).
///
/// vpctl predicts where an MVS algorithm will succeed in each acquired image,
/// plans the camera triplets that most improve coverage, resolution and 3D
/// accuracy while keeping a safety distance, and uploads the mission over
/// MAVLink.
#[derive(Debug, Parser)]
#[command(name = "vpctl", version, about, long_about)]
struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Train on small procedural sites, fly a held-out site with the F, NP
    /// and Grid strategies, print the paper's Table 1, write a report.
    Demo(cmd::demo::DemoArgs),
    /// Procedural scenes: generate a site with materials.
    #[command(subcommand)]
    Scene(cmd::scene::SceneCommand),
    /// Inspect meshes (PLY, OBJ).
    #[command(subcommand)]
    Mesh(cmd::mesh::MeshCommand),
    /// Inspect COLMAP sparse models (text or binary).
    #[command(subcommand)]
    Colmap(cmd::colmap::ColmapCommand),
    /// Inspect COLMAP dense depth maps.
    #[command(subcommand)]
    Depth(cmd::depth::DepthCommand),
    /// Dense multi-view stereo (PatchMatch) on a COLMAP dense workspace.
    #[command(subcommand)]
    Mvs(cmd::mvs::MvsCommand),
    /// Turn a plan into a MAVLink mission: export, upload, download.
    #[command(subcommand)]
    Mission(cmd::mission::MissionCommand),
    /// Training labels without ground truth: triplet sampling and consistency voting.
    #[command(subcommand)]
    Labelgen(cmd::labelgen::LabelgenCommand),
    /// Train the MVS confidence predictor from images and label images.
    Train(cmd::forest::TrainArgs),
    /// Predict confidence images (one channel per angle bin) with a trained model.
    ///
    /// Prints a line per image for up to 20 images, else a summary (the
    /// mean, the lowest and highest image, where the files are).
    Predict(cmd::forest::PredictArgs),
    /// Inspect, evaluate and configure confidence-predictor models.
    #[command(subcommand)]
    Forest(cmd::forest::ForestCommand),
    /// Plan the next camera triplets, or a grid flight (`plan grid`).
    Plan(Box<cmd::plan::PlanArgs>),
    /// Print configuration files (`config --defaults`).
    Config(cmd::plan::ConfigArgs),
    /// The simulated world: render images of procedural sites, run
    /// closed-loop campaigns (`sim run --config`, `sim config --defaults`).
    #[command(subcommand)]
    Sim(cmd::sim::SimCommand),
}

fn run(args: Args, out: &mut dyn Write) -> anyhow::Result<()> {
    match args.command {
        Command::Scene(c) => cmd::scene::run(c, out),
        Command::Mesh(c) => cmd::mesh::run(c, out),
        Command::Colmap(c) => cmd::colmap::run(c, out),
        Command::Depth(c) => cmd::depth::run(c, out),
        Command::Mission(c) => cmd::mission::run(c, out),
        Command::Mvs(c) => cmd::mvs::run(c, out),
        Command::Labelgen(c) => cmd::labelgen::run(c, out),
        Command::Train(c) => cmd::forest::train(&c, out),
        Command::Predict(c) => cmd::forest::predict(&c, out),
        Command::Forest(c) => cmd::forest::run(c, out),
        Command::Plan(c) => cmd::plan::run(*c, out),
        Command::Config(c) => cmd::plan::run_config(c, out),
        Command::Sim(c) => cmd::sim::run(c, out),
        Command::Demo(c) => cmd::demo::run_demo(&c, out),
    }
}

/// Old spellings kept as hidden aliases: (command, old flag, new flag).
/// The command is the first word after `vpctl` ("" matches any).
const DEPRECATED_FLAGS: &[(&str, &str, &str)] = &[
    ("labelgen", "--model", "--colmap"),
    ("colmap", "--model", "--colmap"),
    ("plan", "--cameras", "--colmap"),
    ("predict", "--model", "--forest"),
    ("forest", "--model", "--forest"),
    ("demo", "--model", "--forest"),
    ("sim", "--model", "--forest"),
    ("demo", "--save-model", "--save-forest"),
    ("sim", "--save-model", "--save-forest"),
    ("labelgen", "--out-dir", "--out"),
    ("labelgen", "--params", "--config"),
];

/// Deprecation notes for the old spellings in `argv` (one per flag used).
fn deprecation_notes(argv: &[String]) -> Vec<String> {
    let Some(command) = argv.get(1) else {
        return Vec::new();
    };
    let mut notes = Vec::new();
    for a in argv.iter().skip(2).take_while(|a| *a != "--") {
        let flag = a.split('=').next().unwrap_or(a);
        for (cmd, old, new) in DEPRECATED_FLAGS {
            if cmd == command && flag == *old {
                let note = format!(
                    "warning: `vpctl {command} {old}` is deprecated and will be removed; use {new}"
                );
                if !notes.contains(&note) {
                    notes.push(note);
                }
            }
        }
    }
    notes
}

fn main() -> ExitCode {
    let argv_os: Vec<std::ffi::OsString> = std::env::args_os().collect();
    let argv: Vec<String> = argv_os
        .iter()
        .map(|a| a.to_string_lossy().into_owned())
        .collect();
    let args = Args::parse_from(&argv_os);
    for note in deprecation_notes(&argv) {
        eprintln!("{note}");
    }
    let stdout = io::stdout();
    let mut out = stdout.lock();
    match run(args, &mut out).and_then(|()| out.flush().map_err(Into::into)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if is_broken_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            let top = e.to_string();
            eprintln!("error: {top}");
            // Library errors often print their source inline already.
            for cause in e.chain().skip(1) {
                let cause = cause.to_string();
                if !top.contains(&cause) {
                    eprintln!("  caused by: {cause}");
                }
            }
            ExitCode::from(cmd::exit_code(&e))
        }
    }
}

fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain()
        .filter_map(|c| c.downcast_ref::<io::Error>())
        .any(|io| io.kind() == io::ErrorKind::BrokenPipe)
}
