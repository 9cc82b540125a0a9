//! The docs say what the code does. The crate drawing and edge list of
//! docs/architecture.md are `cargo metadata`'s dependency edges, and every
//! particle count quoted in README.md and scenes/README.md is what its
//! scene samples or what `firn check` estimates for it.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

use firn_core::scene::sampling::sample_bodies;
use firn_core::scene::{FlowSettings, Scene, SceneKind};

mod common;
use common::{firn_binary, text};

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn read_doc(relative: &str) -> String {
    fs::read_to_string(workspace_root().join(relative)).expect("the doc is readable")
}

/// A crate's workspace dependencies: (name, whether optional).
type Edges = BTreeMap<String, BTreeSet<(String, bool)>>;

/// The normal (not dev, not build) dependencies between workspace members,
/// optional ones included, as `cargo metadata --no-deps` lists them.
fn metadata_edges() -> Edges {
    let output = Command::new(env!("CARGO"))
        .args(["metadata", "--format-version", "1", "--no-deps"])
        .current_dir(workspace_root())
        .output()
        .expect("cargo metadata runs");
    assert!(output.status.success(), "{}", text(&output.stderr));
    let metadata: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    let packages = metadata["packages"].as_array().unwrap();
    let members: BTreeSet<&str> = packages
        .iter()
        .map(|p| p["name"].as_str().unwrap())
        .collect();
    let mut edges = Edges::new();
    for package in packages {
        let deps = package["dependencies"].as_array().unwrap().iter();
        let normal = deps.filter(|dep| dep["kind"].is_null());
        let workspace = normal.filter(|dep| members.contains(dep["name"].as_str().unwrap()));
        let list = workspace.map(|dep| {
            let optional = dep["optional"].as_bool().unwrap_or(false);
            (dep["name"].as_str().unwrap().to_string(), optional)
        });
        edges
            .entry(package["name"].as_str().unwrap().to_string())
            .or_default()
            .extend(list);
    }
    edges
}

/// The fenced blocks of the section of `doc` under `heading`.
fn fenced_blocks(doc: &str, heading: &str) -> Vec<Vec<String>> {
    let start = doc.find(heading).expect("the section exists");
    let section = &doc[start + heading.len()..];
    let section = &section[..section.find("\n## ").unwrap_or(section.len())];
    let mut blocks = Vec::new();
    let mut open: Option<Vec<String>> = None;
    for line in section.lines() {
        match (line.starts_with("```"), open.take()) {
            (true, None) => open = Some(Vec::new()),
            (true, Some(block)) => blocks.push(block),
            (false, Some(mut block)) => {
                block.push(line.to_string());
                open = Some(block);
            }
            (false, None) => {}
        }
    }
    blocks
}

/// The edge list of docs/architecture.md: `crate -> dep, dep (optional)`.
fn documented_edges(block: &[String]) -> Edges {
    let mut edges = Edges::new();
    for line in block {
        let (from, to) = line.split_once("->").expect("an edge line has ->");
        let deps = to.split(',').map(str::trim).filter(|dep| !dep.is_empty());
        let list = deps.map(|dep| match dep.strip_suffix("(optional)") {
            Some(name) => (name.trim().to_string(), true),
            None => (dep.to_string(), false),
        });
        let previous = edges.insert(from.trim().to_string(), list.collect());
        assert!(previous.is_none(), "{} has two lines", from.trim());
    }
    edges
}

/// The crates of the drawing, top to bottom (a line naming a crate starts
/// with its name).
fn drawn_order(block: &[String]) -> Vec<String> {
    let names = block
        .iter()
        .filter_map(|line| line.split_whitespace().next());
    names
        .filter(|name| name.starts_with("firn-"))
        .map(str::to_string)
        .collect()
}

fn architecture_blocks() -> Vec<Vec<String>> {
    let doc = read_doc("docs/architecture.md");
    let blocks = fenced_blocks(&doc, "## Crates, and the one-way flow between them");
    assert_eq!(
        blocks.len(),
        2,
        "the section has the drawing, then the edge list"
    );
    blocks
}

/// Each edge as `crate -> dep` (with ` (optional)`).
fn edge_lines(edges: &Edges) -> BTreeSet<String> {
    let lines = edges.iter().flat_map(|(krate, deps)| {
        deps.iter().map(move |(dep, optional)| {
            let mark = if *optional { " (optional)" } else { "" };
            format!("{krate} -> {dep}{mark}")
        })
    });
    lines.collect()
}

#[test]
fn the_architecture_edge_list_is_cargo_metadatas() {
    let documented = documented_edges(&architecture_blocks()[1]);
    let actual = metadata_edges();
    let (listed, real) = (edge_lines(&documented), edge_lines(&actual));
    let missing: Vec<&String> = real.difference(&listed).collect();
    let extra: Vec<&String> = listed.difference(&real).collect();
    assert!(
        missing.is_empty() && extra.is_empty(),
        "docs/architecture.md lacks {missing:?} (cargo metadata has them) and lists {extra:?} \
         (which no Cargo.toml has)"
    );
    let crates = |edges: &Edges| edges.keys().cloned().collect::<Vec<_>>();
    assert_eq!(
        crates(&documented),
        crates(&actual),
        "a line per workspace member"
    );
}

#[test]
fn the_architecture_drawing_puts_every_crate_below_its_dependencies() {
    let order = drawn_order(&architecture_blocks()[0]);
    let row = |name: &str| order.iter().position(|drawn| drawn == name);
    for (krate, deps) in metadata_edges() {
        let below = row(&krate).unwrap_or_else(|| panic!("the drawing lacks {krate}"));
        for (dep, _) in deps {
            let above = row(&dep).unwrap_or_else(|| panic!("the drawing lacks {dep}"));
            assert!(
                above < below,
                "the drawing puts {dep} below {krate}, which depends on it"
            );
        }
    }
}

/// What a quoted particle count claims.
#[derive(Clone, Debug, PartialEq)]
enum Claim {
    /// `N particles` (at the start, or `at T s` for a flow): the run's count.
    Run { seconds: f64 },
    /// `about N particles`: `firn check`'s estimate.
    Estimate,
    /// `up to N particles`: a flow's slots.
    UpTo,
}

/// Where a count's figure comes from: a bundled scene, or the bench's
/// snowball at a target particle count and grid.
#[derive(Clone, Debug, PartialEq)]
enum Source {
    Scene(String),
    Bench { particles: String, grid: String },
}

/// One particle count of a doc.
#[derive(Debug)]
struct Quoted {
    count: u64,
    claim: Claim,
    source: Option<Source>,
    text: String,
}

/// A word without the punctuation around it.
fn bare(word: &str) -> &str {
    word.trim_matches(|c: char| "()[],.;:`*'\"".contains(c))
}

/// The number a word spells with digits and thousands commas.
fn number(word: &str) -> Option<u64> {
    let digits = bare(word);
    let plain = digits.chars().all(|c| c.is_ascii_digit() || c == ',');
    let first = digits.chars().next().is_some_and(|c| c.is_ascii_digit());
    (plain && first).then(|| digits.replace(',', "").parse().ok())?
}

/// A scene or bench a word names (`scenes/NAME.toml`, or the first two
/// numbers after `firn bench --particles` / `bench-vs-peer.sh`).
fn source_at(words: &[&str], i: usize) -> Option<Source> {
    let word = bare(words[i]);
    if let Some(name) = word
        .strip_prefix("scenes/")
        .and_then(|w| w.strip_suffix(".toml"))
    {
        let file = workspace_root().join("scenes").join(format!("{name}.toml"));
        return file.exists().then(|| Source::Scene(name.to_string()));
    }
    let after = |k: usize| words.get(i + k).map(|w| bare(w).to_string());
    let number = |k: usize| after(k).filter(|w| w.parse::<u64>().is_ok());
    if word.ends_with("bench-vs-peer.sh") {
        return Some(Source::Bench {
            particles: number(1)?,
            grid: number(2)?,
        });
    }
    if word == "bench" && after(1)? == "--particles" && after(3)? == "--grid" {
        return Some(Source::Bench {
            particles: after(2)?,
            grid: after(4)?,
        });
    }
    None
}

/// The scene a heading names first (`## NAME: ...`), if it is bundled.
fn heading_scene(line: &str) -> Option<Source> {
    let first = line.trim_start_matches('#').split_whitespace().next()?;
    let name = first.trim_end_matches(':');
    let file = workspace_root().join("scenes").join(format!("{name}.toml"));
    file.exists().then(|| Source::Scene(name.to_string()))
}

/// The paragraphs of a doc, each with the scene of its section; list
/// items are paragraphs of their own, fenced code is left out.
fn paragraphs(doc: &str) -> Vec<(String, Option<Source>)> {
    let mut out: Vec<(String, Option<Source>)> = Vec::new();
    let mut section = None;
    let mut current = String::new();
    let mut flush = |current: &mut String, section: &Option<Source>| {
        if !current.trim().is_empty() {
            out.push((std::mem::take(current), section.clone()));
        }
        current.clear();
    };
    let mut fenced = false;
    for line in doc.lines() {
        if line.starts_with("```") {
            fenced = !fenced;
            flush(&mut current, &section);
            continue;
        }
        if fenced {
            continue;
        }
        if line.starts_with('#') {
            flush(&mut current, &section);
            section = heading_scene(line);
            continue;
        }
        if line.trim().is_empty() || line.starts_with("- ") {
            flush(&mut current, &section);
        }
        current.push_str(line);
        current.push(' ');
    }
    flush(&mut current, &section);
    out
}

/// The claim of the count at word `i`, from the words around it.
fn claim_at(words: &[&str], i: usize, next: usize) -> Claim {
    let before = |k: usize| i.checked_sub(k).map(|j| bare(words[j]).to_lowercase());
    if before(1).as_deref() == Some("about") {
        return Claim::Estimate;
    }
    if before(1).as_deref() == Some("to") && before(2).as_deref() == Some("up") {
        return Claim::UpTo;
    }
    let after = |k: usize| words.get(next + k).map(|w| bare(w).to_string());
    let seconds = match (after(0).as_deref(), after(1), after(2).as_deref()) {
        (Some("at"), Some(t), Some("s")) => t.parse().unwrap_or(0.0),
        _ => 0.0,
    };
    Claim::Run { seconds }
}

/// Every `N particles` (or `N-particle`; not `N particles per ...`) of a
/// doc, with its claim and the last scene named before it in its
/// paragraph, else its section's, else the first named after it.
fn quoted_counts(doc: &str) -> Vec<Quoted> {
    let mut found = Vec::new();
    for (paragraph, section) in paragraphs(doc) {
        let words: Vec<&str> = paragraph.split_whitespace().collect();
        let mut source = section.clone();
        for i in 0..words.len() {
            source = source_at(&words, i).or(source);
            let hyphenated = bare(words[i]).strip_suffix("-particle");
            let (count, next) = match hyphenated {
                Some(digits) => (number(digits), i + 1),
                None => {
                    let follows = words.get(i + 1).map(|w| bare(w));
                    let is_count = matches!(follows, Some("particles" | "particle"));
                    // `N particles per cell` is a density, not a count.
                    let per = words.get(i + 2).is_some_and(|w| bare(w) == "per");
                    (number(words[i]).filter(|_| is_count && !per), i + 2)
                }
            };
            if let Some(count) = count {
                let first = (i + 1).saturating_sub(3);
                let end = (next + 3).min(words.len());
                found.push(Quoted {
                    count,
                    claim: claim_at(&words, i, next),
                    source: source.clone().or_else(|| later_source(&words, i)),
                    text: words[first..end].join(" "),
                });
            }
        }
    }
    found
}

/// The first scene or bench named after word `i` (for a count whose
/// paragraph names its source only after it).
fn later_source(words: &[&str], i: usize) -> Option<Source> {
    (i..words.len()).find_map(|j| source_at(words, j))
}

fn load_scene(name: &str) -> Scene {
    let path = workspace_root().join("scenes").join(format!("{name}.toml"));
    Scene::load(&path).unwrap_or_else(|error| panic!("scenes/{name}.toml: {error}"))
}

fn flow_settings(scene: &Scene) -> &FlowSettings {
    let settings = scene.kind.flow();
    settings.unwrap_or_else(|| {
        panic!(
            "{} is not a flow: `up to` and `at T s` are a flow's",
            scene.name
        )
    })
}

/// A flow's particles at `seconds`: every emitter's births by then (the
/// schedule `FlowSimulation` emits by; particles are never removed).
fn flow_particles_at(scene: &Scene, seconds: f64) -> u64 {
    let emitters = flow_settings(scene).emitters.iter();
    let born = emitters.map(|emitter| {
        let slots = emitter.slots(scene.time.duration);
        firn_flow::emitters::births_by(emitter, slots, seconds)
    });
    born.sum()
}

/// What the scene's run has: sampled bodies, or a flow's births by `seconds`.
fn run_count(scene: &Scene, seconds: f64) -> u64 {
    match scene.kind {
        SceneKind::Flow(_) => flow_particles_at(scene, seconds),
        SceneKind::Snow => {
            assert_eq!(seconds, 0.0, "a snow count is the count at the start");
            sample_bodies(scene).len() as u64
        }
    }
}

/// The particles `firn bench` samples for a target count and grid.
fn bench_count(particles: &str, grid: &str) -> u64 {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("bench.json");
    let args = [
        "bench",
        "--backend",
        "cpu",
        "--transfer",
        "apic",
        "--steps",
        "1",
    ];
    let output = Command::new(firn_binary())
        .args(args)
        .args(["--warmup", "0", "--particles", particles, "--grid", grid])
        .args(["--json", json.to_str().unwrap()])
        .output()
        .expect("firn bench runs");
    assert!(output.status.success(), "{}", text(&output.stderr));
    let stdout = text(&output.stdout);
    let field = stdout
        .split_whitespace()
        .find_map(|w| w.strip_prefix("particles="));
    field
        .expect("firn bench prints particles=")
        .parse()
        .unwrap()
}

/// The figure the docs should quote for `quoted`.
fn expected(quoted: &Quoted) -> u64 {
    let source = quoted.source.as_ref().unwrap_or_else(|| {
        panic!(
            "\"{}\": no scene for this count; name it (`scenes/NAME.toml`) before it",
            quoted.text
        )
    });
    let name = match source {
        Source::Bench { particles, grid } => return bench_count(particles, grid),
        Source::Scene(name) => name,
    };
    let scene = load_scene(name);
    match quoted.claim {
        Claim::Run { seconds } => run_count(&scene, seconds),
        Claim::Estimate => scene.estimate().particles,
        Claim::UpTo => {
            let emitters = flow_settings(&scene).emitters.iter();
            emitters
                .map(|emitter| emitter.slots(scene.time.duration))
                .sum()
        }
    }
}

/// Checks every count of a doc; returns how many there are.
fn check_counts(doc_path: &str) -> usize {
    let quoted = quoted_counts(&read_doc(doc_path));
    let wrong: Vec<String> = quoted
        .iter()
        .filter_map(|count| {
            let expected = expected(count);
            let claim = (count.claim.clone(), count.source.clone());
            (count.count != expected)
                .then(|| format!("\"{}\" ({claim:?}) should say {expected}", count.text))
        })
        .collect();
    assert!(wrong.is_empty(), "{doc_path}:\n{}", wrong.join("\n"));
    quoted.len()
}

#[test]
fn the_particle_counts_of_the_readme_are_the_scenes() {
    let found = check_counts("README.md");
    assert!(
        found >= 2,
        "only {found} counts found: has the reading broken?"
    );
}

#[test]
fn the_particle_counts_of_the_scenes_readme_are_the_scenes() {
    let found = check_counts("scenes/README.md");
    assert!(
        found >= 15,
        "only {found} counts found: has the reading broken?"
    );
}

#[test]
fn counts_are_read_with_their_claim_and_scene() {
    let doc = "## tower: a tower\n\nIt has 46,857 particles, about 46,904\nparticles, 8 particles per cell.\n\n\
               ## smoke\n\nThe demo (`scenes/curl-noise-demo.toml`) has 22,501 particles \
               at 3 s and up to 55,000 particles; the 183,436-particle bunny.\n";
    let quoted = quoted_counts(doc);
    let found: Vec<(u64, Claim, Option<Source>)> = quoted
        .into_iter()
        .map(|q| (q.count, q.claim, q.source))
        .collect();
    let scene = |name: &str| Some(Source::Scene(name.to_string()));
    let at_start = Claim::Run { seconds: 0.0 };
    assert_eq!(
        found,
        vec![
            (46_857, at_start.clone(), scene("tower")),
            (46_904, Claim::Estimate, scene("tower")),
            (
                22_501,
                Claim::Run { seconds: 3.0 },
                scene("curl-noise-demo")
            ),
            (55_000, Claim::UpTo, scene("curl-noise-demo")),
            (183_436, at_start, scene("curl-noise-demo")),
        ]
    );
}

/// docs/benchmarks.md is a reference of current figures, kept short: the
/// history of tried changes goes to docs/benchmark-history.md.
#[test]
fn the_benchmarks_reference_stays_short() {
    let path = workspace_root().join("docs/benchmarks.md");
    let lines = std::fs::read_to_string(&path).unwrap().lines().count();
    assert!(
        lines <= 400,
        "docs/benchmarks.md has {lines} lines: move history and before/after narrative to docs/benchmark-history.md"
    );
}
