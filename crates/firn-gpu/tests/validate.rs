//! Every WGSL program validates with naga, no adapter needed.

use firn_gpu::shaders::PROGRAMS;

/// [`Program::reflect`](firn_gpu::shaders::Program::reflect) parses and
/// validates the program with naga and panics with naga's message if
/// either fails.
#[test]
fn every_wgsl_program_validates_with_naga() {
    assert!(!PROGRAMS.is_empty());
    for program in PROGRAMS {
        let reflection = program.reflect();
        assert!(
            reflection.entry_points().next().is_some(),
            "{}",
            program.name
        );
    }
}

#[test]
fn every_program_has_entry_points_and_no_placeholder() {
    for program in PROGRAMS {
        let source = program.source();
        assert!(
            source.contains("@compute"),
            "{} has no kernel",
            program.name
        );
        assert!(
            !source.contains("placeholder"),
            "{} is unfinished",
            program.name
        );
    }
}
