//! Every WGSL program validates with naga, no adapter needed.

use firn_gpu::shaders::PROGRAMS;

#[test]
fn every_wgsl_program_validates_with_naga() {
    assert!(!PROGRAMS.is_empty());
    for program in PROGRAMS {
        let source = program.source();
        let module = naga::front::wgsl::parse_str(&source).unwrap_or_else(|error| {
            panic!(
                "{} does not parse:\n{}",
                program.name,
                error.emit_to_string(&source)
            )
        });
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::empty(),
        )
        .validate(&module)
        .unwrap_or_else(|error| {
            panic!(
                "{} does not validate:\n{}",
                program.name,
                error.emit_to_string(&source)
            )
        });
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
