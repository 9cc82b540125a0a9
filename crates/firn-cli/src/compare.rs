//! `firn compare`: the thesis' comparison figures (14-18) as one picture, a
//! row per scene variant and a column per simulated time, with the numbers
//! behind every still (particle count, centre of mass, bounding box) in a
//! JSON file next to it.

use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::{Args, ValueEnum};
use firn_core::Scene;
use firn_core::scene::RenderStyle;
use firn_io::{ensure_writable_dir, write_atomically};
use firn_render::legend::{draw_text, text_width};
use firn_render::output::write_png;
use firn_render::scene_view::{FrameParticles, scene_picture};
use firn_run::run_dir::style_name;
use firn_run::{Placement, Solver};
use image::{Rgb, RgbImage};
use serde::Serialize;

use crate::Failure;
use crate::compare_layout::{GLYPH_PIXELS, Layout, layout_for};
use crate::scene_source::load_scene;
use firn_run::pictures::frame_particles;

/// The times of the thesis' figures 14-18, in seconds.
const THESIS_TIMES: &str = "0.901,1.0,1.233,1.644,4.054";
/// Colour behind the panels and the labels.
const BACKGROUND: [u8; 3] = [24, 26, 32];
/// Colour of the labels.
const INK: [u8; 3] = [235, 238, 242];

/// Arguments of `firn compare`.
#[derive(Args, Debug)]
pub struct CompareArgs {
    /// Scene files (TOML), one row of the picture each, top to bottom.
    #[arg(required = true)]
    pub scenes: Vec<PathBuf>,
    /// Simulated times of the columns in seconds, ascending.
    #[arg(
        long,
        value_delimiter = ',',
        allow_hyphen_values = true,
        default_value = THESIS_TIMES
    )]
    pub times: Vec<f64>,
    /// How the snow is drawn (default: each scene's first render style).
    #[arg(long, value_enum)]
    pub style: Option<CompareStyle>,
    /// Size of each panel as WIDTHxHEIGHT.
    #[arg(long, default_value = "480x270")]
    pub size: String,
    /// The picture (PNG); its numbers go next to it, as the same name with `.json`.
    #[arg(long, default_value = "compare.png")]
    pub out: PathBuf,
    /// Worker threads (default: all cores). Results are identical for any count.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Draw each scene's colour legend in its panels (off by default: a grid
    /// of panels reads better without one in every panel).
    #[arg(long)]
    pub legend: bool,
    /// Print nothing but errors and the final summary line.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Snow styles of `firn compare`.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum CompareStyle {
    /// Sphere-shaded sprites with the bluish ramp (the thesis' look).
    Points,
    /// Ray-marched density with self-shadowing.
    Volume,
}

impl CompareStyle {
    fn render_style(self) -> RenderStyle {
        match self {
            CompareStyle::Points => RenderStyle::Points,
            CompareStyle::Volume => RenderStyle::Volume,
        }
    }
}

/// Simulates every scene to every time and writes the picture and its numbers.
pub fn compare(args: CompareArgs) -> Result<(), Failure> {
    let plan = Plan::new(&args)?;
    if !args.quiet {
        plan.note_times_past_the_end();
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads.unwrap_or(0))
        .build()
        .map_err(|error| Failure::Failed(format!("error: cannot start the threads: {error}")))?;
    let started = Instant::now();
    let mut canvas = RgbImage::from_pixel(plan.layout.width, plan.layout.height, Rgb(BACKGROUND));
    for (text, rect) in plan.headers.iter().zip(&plan.layout.headers) {
        let indent = rect.width.saturating_sub(text_width(text, plan.scale)) / 2;
        draw_text(
            &mut canvas,
            text,
            rect.x + indent,
            rect.y,
            plan.scale,
            Rgb(INK),
        );
    }
    for (text, rect) in plan.labels.iter().zip(&plan.layout.labels) {
        let drop = rect.height.saturating_sub(GLYPH_PIXELS * plan.scale) / 2;
        draw_text(
            &mut canvas,
            text,
            rect.x,
            rect.y + drop,
            plan.scale,
            Rgb(INK),
        );
    }
    let rows = pool.install(|| {
        plan.simulate(args.quiet, |row, column, panel| {
            let rect = plan.layout.panels[row][column];
            image::imageops::replace(&mut canvas, panel, rect.x.into(), rect.y.into());
        })
    })?;
    write_png(&plan.out, &canvas).map_err(|error| Failure::Failed(format!("error: {error}")))?;
    plan.write_report(rows)?;
    outln!(
        "firn: {} scene(s) at {} time(s) in {:.1} s; picture in {}, numbers in {}",
        plan.scenes.len(),
        plan.times.len(),
        started.elapsed().as_secs_f64(),
        plan.out.display(),
        plan.report.display()
    );
    Ok(())
}

/// A scene to compare, loaded and checked.
struct Entry {
    file: PathBuf,
    scene: Scene,
    style: RenderStyle,
}

/// Everything decided before simulating: scenes, times, texts and layout.
struct Plan {
    scenes: Vec<Entry>,
    times: Vec<f64>,
    panel: [u32; 2],
    labels: Vec<String>,
    headers: Vec<String>,
    layout: Layout,
    scale: u32,
    out: PathBuf,
    report: PathBuf,
}

impl Plan {
    /// Checks the arguments and loads the scenes; writes nothing unless all
    /// are good (then it makes sure the picture's folder is writable).
    fn new(args: &CompareArgs) -> Result<Plan, Failure> {
        check_times(&args.times).map_err(Failure::BadInput)?;
        let panel = crate::render::parse_size(&args.size)?;
        if args.threads == Some(0) {
            return Err(Failure::BadInput(
                "error: --threads must be at least 1\n  fix: pass --threads 1 or more, or leave it out to use all cores".into(),
            ));
        }
        let report = report_path(&args.out).map_err(Failure::BadInput)?;
        let mut scenes = Vec::with_capacity(args.scenes.len());
        for file in &args.scenes {
            let (mut scene, _) = load_scene(Some(file))?;
            scene.render.legend = args.legend;
            let style = args.style.map_or_else(
                || {
                    scene
                        .render
                        .styles
                        .first()
                        .copied()
                        .unwrap_or(RenderStyle::Points)
                },
                CompareStyle::render_style,
            );
            scenes.push(Entry {
                file: file.clone(),
                scene,
                style,
            });
        }
        let folder = match args.out.parent() {
            Some(parent) if !parent.as_os_str().is_empty() => parent,
            _ => Path::new("."),
        };
        ensure_writable_dir(folder).map_err(|error| {
            Failure::BadInput(format!(
                "error: {error}\n  fix: choose a writable place for the picture with --out FILE.png"
            ))
        })?;
        let labels = row_labels(&scenes);
        let headers: Vec<String> = args
            .times
            .iter()
            .map(|&time| format!("t = {} s", time_text(time)))
            .collect();
        let (layout, scale) = layout_for(&labels, &headers, panel);
        Ok(Plan {
            scenes,
            times: args.times.clone(),
            panel,
            labels,
            headers,
            layout,
            scale,
            out: args.out.clone(),
            report,
        })
    }

    /// Says which scenes are asked for times past their duration.
    fn note_times_past_the_end(&self) {
        for (entry, label) in self.scenes.iter().zip(&self.labels) {
            let duration = entry.scene.time.duration;
            let late: Vec<String> = self
                .times
                .iter()
                .filter(|&&time| time > duration)
                .map(|&time| time_text(time))
                .collect();
            if !late.is_empty() {
                errln!(
                    "note: {label} lasts {duration} s; t = {} s {} past its end (the simulation simply continues)",
                    late.join(", "),
                    if late.len() == 1 { "is" } else { "are" }
                );
            }
        }
    }

    /// Simulates each scene in turn through the times, handing each still to
    /// `paste` (row, column, picture); returns the numbers.
    fn simulate(
        &self,
        quiet: bool,
        mut paste: impl FnMut(usize, usize, &RgbImage),
    ) -> Result<Vec<SceneRow>, Failure> {
        let total = self.scenes.len() * self.times.len();
        let started = Instant::now();
        let mut rows = Vec::with_capacity(self.scenes.len());
        for (row, (entry, label)) in self.scenes.iter().zip(&self.labels).enumerate() {
            // Stills are compared side by side: all on the CPU, the same method.
            let mut solver =
                Solver::new(entry.scene.clone(), &Placement::Cpu).map_err(|error| {
                    Failure::BadInput(format!("error: {}: {error}", entry.file.display()))
                })?;
            let mut substeps = 0u64;
            let mut stills = Vec::with_capacity(self.times.len());
            for (column, &time) in self.times.iter().enumerate() {
                let still_started = Instant::now();
                substeps += u64::from(solver.advance_to(time).map_err(|error| {
                    Failure::Failed(format!(
                        "error: the simulation of {label} ({}) stopped on its way to t = {time} s: {error}",
                        entry.file.display()
                    ))
                })?);
                let host = solver
                    .host()
                    .map_err(|error| Failure::Failed(format!("error: {error}")))?;
                let particles = host.particles(host.scene().render.color_by);
                let frame = frame_particles(&particles);
                let picture =
                    scene_picture(&entry.scene, time, entry.style, frame, Some(self.panel));
                let (panel, measures) = (firn_render::render(&picture), Measures::of(frame));
                paste(row, column, &panel);
                let wall_seconds = still_started.elapsed().as_secs_f64();
                if !quiet {
                    errln!(
                        "still {}/{total}: {label} at t = {} s, {substeps} substeps so far, {wall_seconds:.1} s ({:.1} s in all)",
                        row * self.times.len() + column + 1,
                        time_text(time),
                        started.elapsed().as_secs_f64()
                    );
                }
                stills.push(Still {
                    time,
                    past_duration: time > entry.scene.time.duration,
                    substeps,
                    wall_seconds,
                    measures,
                });
            }
            rows.push(SceneRow {
                file: entry.file.display().to_string(),
                label: label.clone(),
                style: style_name(entry.style),
                duration: entry.scene.time.duration,
                stills,
            });
        }
        Ok(rows)
    }

    /// Writes the JSON report next to the picture.
    fn write_report(&self, scenes: Vec<SceneRow>) -> Result<(), Failure> {
        let report = Report {
            picture: self.out.display().to_string(),
            note: "wall_seconds is this machine's time to simulate up to a still and render it; every other number is the same for any thread count",
            times: &self.times,
            panel_size: self.panel,
            layout: &self.layout,
            scenes,
        };
        let text = serde_json::to_string_pretty(&report)
            .map_err(|error| Failure::Failed(format!("error: {error}")))?;
        write_atomically(&self.report, |file| {
            file.write_all(text.as_bytes())?;
            file.write_all(b"\n")
        })
        .map_err(|error| Failure::Failed(format!("error: {error}")))
    }
}

/// The JSON report: the picture's layout and the numbers of every still.
#[derive(Serialize)]
struct Report<'a> {
    picture: String,
    note: &'static str,
    times: &'a [f64],
    panel_size: [u32; 2],
    layout: &'a Layout,
    scenes: Vec<SceneRow>,
}

/// One scene's row of the report.
#[derive(Serialize)]
struct SceneRow {
    file: String,
    label: String,
    style: &'static str,
    duration: f64,
    stills: Vec<Still>,
}

/// One still of the report.
#[derive(Serialize)]
struct Still {
    time: f64,
    past_duration: bool,
    /// Substeps of the scene from time 0 to this still.
    substeps: u64,
    wall_seconds: f64,
    #[serde(flatten)]
    measures: Measures,
}

/// What a still shows, in numbers.
#[derive(Debug, PartialEq, Serialize)]
struct Measures {
    particles: usize,
    /// Mass-weighted mean position (`null` without particles).
    center_of_mass: Option<[f64; 3]>,
    /// Axis-aligned bounding box of the positions (`null` without particles).
    bounds: Option<Bounds>,
}

/// An axis-aligned box.
#[derive(Debug, PartialEq, Serialize)]
struct Bounds {
    min: [f32; 3],
    max: [f32; 3],
}

impl Measures {
    /// Counts and measures a frame's particles (unit masses where none are known).
    fn of(frame: FrameParticles<'_>) -> Measures {
        let positions = frame.positions;
        let (Some(&first), particles) = (positions.first(), positions.len()) else {
            return Measures {
                particles: 0,
                center_of_mass: None,
                bounds: None,
            };
        };
        let (mut min, mut max) = (first, first);
        let mut moment = [0.0f64; 3];
        let mut mass = 0.0f64;
        for (index, &position) in positions.iter().enumerate() {
            min = min.min(position);
            max = max.max(position);
            let m = frame.masses.map_or(1.0, |masses| f64::from(masses[index]));
            for (sum, coordinate) in moment.iter_mut().zip(position.to_array()) {
                *sum += m * f64::from(coordinate);
            }
            mass += m;
        }
        Measures {
            particles,
            center_of_mass: Some(moment.map(|sum| sum / mass)),
            bounds: Some(Bounds {
                min: min.to_array(),
                max: max.to_array(),
            }),
        }
    }
}

/// Checks that the times are positive, finite and strictly increasing.
fn check_times(times: &[f64]) -> Result<(), String> {
    let fix = format!(
        "  fix: list positive times in seconds in ascending order, e.g. --times {THESIS_TIMES}"
    );
    if times.is_empty() {
        return Err(format!("error: --times names no time\n{fix}"));
    }
    if let Some(time) = times
        .iter()
        .find(|time| !(time.is_finite() && **time > 0.0))
    {
        return Err(format!(
            "error: --times {time} is not a positive number of seconds\n{fix}"
        ));
    }
    if let Some(pair) = times.windows(2).find(|pair| pair[1] <= pair[0]) {
        return Err(format!(
            "error: --times must increase, but {} comes after {}\n{fix}",
            pair[1], pair[0]
        ));
    }
    Ok(())
}

/// The report's path: the picture's with the extension `.json`.
fn report_path(out: &Path) -> Result<PathBuf, String> {
    let is_json = out.extension().is_some_and(|extension| extension == "json");
    if is_json || out.is_dir() || out.file_name().is_none() {
        return Err(format!(
            "error: --out {} cannot be the picture: it must name a file (the numbers go next to it as .json)\n  fix: pass a PNG file name, e.g. --out compare.png",
            out.display()
        ));
    }
    Ok(out.with_extension("json"))
}

/// Row labels: each scene's name, or its file stem where names repeat.
fn row_labels(scenes: &[Entry]) -> Vec<String> {
    scenes
        .iter()
        .map(|entry| {
            let name = &entry.scene.name;
            let repeated = scenes
                .iter()
                .filter(|other| &other.scene.name == name)
                .count()
                > 1;
            match entry.file.file_stem() {
                Some(stem) if repeated => stem.to_string_lossy().into_owned(),
                _ => name.clone(),
            }
        })
        .collect()
}

/// A time for labels: up to four decimals, at least one.
fn time_text(time: f64) -> String {
    let text = format!("{time:.4}");
    let trimmed = text.trim_end_matches('0');
    if trimmed.ends_with('.') {
        format!("{trimmed}0")
    } else {
        trimmed.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn times_must_be_positive_and_increasing() {
        assert!(check_times(&[0.901, 1.0, 4.054]).is_ok());
        let message = check_times(&[0.5, 0.2]).expect_err("unsorted");
        assert!(message.contains("0.2 comes after 0.5") && message.contains("fix:"));
        assert!(check_times(&[0.5, 0.5]).is_err());
        assert!(check_times(&[0.0, 1.0]).is_err());
        assert!(check_times(&[f64::NAN]).is_err());
        assert!(check_times(&[]).is_err());
    }

    #[test]
    fn time_labels_keep_what_was_asked_for() {
        assert_eq!(time_text(0.901), "0.901");
        assert_eq!(time_text(1.0), "1.0");
        assert_eq!(time_text(4.054), "4.054");
        assert_eq!(time_text(0.02), "0.02");
        assert_eq!(time_text(12.5), "12.5");
    }

    #[test]
    fn out_paths_are_checked() {
        assert_eq!(
            report_path(Path::new("figs/a.png")),
            Ok(PathBuf::from("figs/a.json"))
        );
        assert!(report_path(Path::new("a.json")).is_err());
    }

    #[test]
    fn repeated_names_fall_back_to_file_stems() {
        let scene = |name: &str, file: &str| {
            let (mut scene, _) = load_scene(None).expect("bundled scene");
            scene.name = name.to_string();
            Entry {
                file: PathBuf::from(file),
                scene,
                style: RenderStyle::Points,
            }
        };
        let scenes = [
            scene("wall", "a/soft.toml"),
            scene("wall", "b/hard.toml"),
            scene("drop", "c/drop-test.toml"),
        ];
        assert_eq!(row_labels(&scenes), ["soft", "hard", "drop"]);
    }

    #[test]
    fn measures_weigh_positions_by_mass() {
        let positions = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 2.0, -1.0)];
        let masses = [1.0, 3.0];
        let frame = FrameParticles {
            positions: &positions,
            masses: Some(&masses),
            values: None,
            trails: None,
            surface: None,
            drift: None,
            rigid_bodies: &[],
        };
        let measures = Measures::of(frame);
        assert_eq!(measures.particles, 2);
        assert_eq!(measures.center_of_mass, Some([0.75, 1.5, -0.75]));
        assert_eq!(
            measures.bounds,
            Some(Bounds {
                min: [0.0, 0.0, -1.0],
                max: [1.0, 2.0, 0.0]
            })
        );
        let empty = Measures::of(FrameParticles {
            positions: &[],
            ..frame
        });
        assert_eq!(empty.center_of_mass, None);
    }
}
