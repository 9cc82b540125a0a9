//! docs/scene-format.md stays true: every ```toml block is a complete scene
//! that loads, and the preset table matches `Material::presets()`.

use std::path::PathBuf;

use firn_core::Scene;
use firn_core::scene::{ColliderGeometry, Material, Shape};

fn document() -> String {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../docs/scene-format.md");
    std::fs::read_to_string(&path)
        .unwrap_or_else(|err| panic!("cannot read {}: {err}", path.display()))
}

/// The contents of every ```toml fence, in order, with the line it starts on.
fn toml_blocks(markdown: &str) -> Vec<(usize, String)> {
    let mut blocks = Vec::new();
    let mut current: Option<(usize, String)> = None;
    for (number, line) in markdown.lines().enumerate() {
        let trimmed = line.trim_start();
        match current.as_mut() {
            None if trimmed.starts_with("```") => {
                let info = trimmed.trim_start_matches('`').trim();
                if info == "toml" {
                    current = Some((number + 2, String::new()));
                } else {
                    // Skip a fence of another language up to its end.
                    current = Some((0, String::new()));
                }
            }
            None => {}
            Some(_) if trimmed.starts_with("```") => {
                let (start, text) = current.take().unwrap();
                if start > 0 {
                    blocks.push((start, text));
                }
            }
            Some((_, text)) => {
                text.push_str(line);
                text.push('\n');
            }
        }
    }
    assert!(current.is_none(), "unclosed code fence in the document");
    blocks
}

#[test]
fn every_toml_example_is_a_valid_scene() {
    let blocks = toml_blocks(&document());
    assert!(
        blocks.len() >= 8,
        "only {} toml examples found",
        blocks.len()
    );
    let mut failures = Vec::new();
    for (index, (line, text)) in blocks.iter().enumerate() {
        // The document's own path, so that mesh files resolve from docs/.
        let origin = concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/scene-format.md");
        if let Err(err) = Scene::from_toml_str(text, origin) {
            failures.push(format!("toml block {} at line {line}:\n{err}", index + 1));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

#[test]
fn first_example_is_the_bundled_default_scene() {
    let blocks = toml_blocks(&document());
    let documented = Scene::from_toml_str(&blocks[0].1, "snowball-wall.toml")
        .unwrap_or_else(|err| panic!("{err}"));
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes/snowball-wall.toml");
    let bundled = Scene::load(&path).unwrap_or_else(|err| panic!("{err}"));
    assert_eq!(
        documented, bundled,
        "the first example of docs/scene-format.md differs from scenes/snowball-wall.toml"
    );

    // A clumpy snowball thrown at the top of a wall that it meets.
    assert_eq!(documented.bodies.len(), 1);
    let ball = &documented.bodies[0];
    let Shape::Sphere { center, radius } = ball.shape else {
        panic!("the snowball is a sphere");
    };
    assert!(ball.velocity.x > 0.0);
    assert!(
        ball.clumps.is_some(),
        "the default snow is packed in clumps"
    );
    let (wall_center, wall_size) = documented
        .colliders
        .iter()
        .find_map(|c| match c.geometry {
            ColliderGeometry::Box { center, size, .. } => Some((center, size)),
            _ => None,
        })
        .expect("a wall");
    assert!(
        wall_center.x > center.x,
        "the wall stands in the ball's way"
    );
    let wall_top = wall_center.y + 0.5 * wall_size.y;
    assert!(
        (center.y - radius..center.y + radius).contains(&wall_top),
        "the ball hits the wall's top edge"
    );
}

/// Parse a number as written in the table (`1.4e5`, `0.025`, `10`).
fn number(cell: &str) -> f32 {
    cell.trim()
        .parse()
        .unwrap_or_else(|_| panic!("not a number in the preset table: {cell:?}"))
}

#[test]
fn preset_table_matches_the_code() {
    let doc = document();
    let marker = doc
        .find("<!-- presets-table")
        .expect("the preset table marker");
    let rows: Vec<Vec<String>> = doc[marker..]
        .lines()
        .skip(1)
        .take_while(|line| line.trim_start().starts_with('|'))
        .skip(2) // header and separator
        .map(|line| {
            line.trim()
                .trim_matches('|')
                .split('|')
                .map(|cell| cell.trim().to_string())
                .collect()
        })
        .collect();

    let presets = Material::presets();
    let names: Vec<&str> = rows.iter().map(|row| row[0].trim_matches('`')).collect();
    let expected: Vec<&str> = presets.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, expected, "preset names or order differ");

    for (row, preset) in rows.iter().zip(&presets) {
        let documented = [1, 2, 3, 4, 5, 6].map(|column| number(&row[column]));
        let actual = [
            preset.youngs_modulus,
            preset.poisson_ratio,
            preset.hardening,
            preset.critical_compression,
            preset.critical_stretch,
            preset.density,
        ];
        for (column, (doc_value, code_value)) in documented.iter().zip(actual).enumerate() {
            assert!(
                (doc_value - code_value).abs() <= 1e-6 * code_value.abs(),
                "preset {}: column {} documents {doc_value} but the code has {code_value}",
                preset.name,
                column + 1
            );
        }
    }
}

#[test]
fn fence_extraction_finds_indented_and_skips_other_languages() {
    let markdown = "text\n```toml\na = 1\n```\n  ```text\nb\n  ```\n```toml\nc = 2\n```\n";
    let blocks = toml_blocks(markdown);
    assert_eq!(
        blocks,
        vec![(3, "a = 1\n".to_string()), (9, "c = 2\n".to_string())]
    );
}
