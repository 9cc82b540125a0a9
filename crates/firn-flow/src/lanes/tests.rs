use super::*;

#[test]
fn floor_matches_the_f64_path() {
    for x in [
        -2.5f32,
        -2.0,
        -1e-7,
        0.0,
        0.3,
        1.0,
        7.99,
        -1000.25,
        1e6 + 0.5,
    ] {
        let (floor, int) = F32s::<1>([x]).floor_int();
        let (floor64, int64) = f64::from(x).floor_int();
        assert_eq!(f64::from(floor.0[0]), floor64, "{x}");
        assert_eq!(int.0[0], int64, "{x}");
    }
}

#[test]
fn integer_masks_work_lane_by_lane() {
    let a = F32s([1.0, 2.0, 3.0, 4.0]);
    let mask = Real::lt(a, F32s([4.0, 3.0, 2.0, 1.0]));
    assert_eq!(F32s::<4>::mask_to_int(mask).0, [1, 1, 0, 0]);
    assert_eq!(F32s::<4>::mask_bits(mask), 0b0011);
    assert!(F32s::<4>::any(mask));
    assert!(!F32s::<4>::any(F32s::<4>::and(mask, F32s::<4>::not(mask))));
}
