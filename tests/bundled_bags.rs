//! The bundled bags are what `stereocal synth` makes: regenerating one with the command
//! in bags/README.md gives the same bytes.

use std::path::Path;

use stereocal::cli::demo::{BUNDLED_STEREO, bundled_stereo_args};

#[test]
fn bundled_stereo_scene_is_reproduced_byte_for_byte_by_synth() {
    let bundled = Path::new(env!("CARGO_MANIFEST_DIR")).join(BUNDLED_STEREO);
    let dir = tempfile::tempdir().expect("temp dir");
    let made = dir.path().join("stereo");
    stereocal::cli::synth::run(&bundled_stereo_args(made.clone())).expect("synth");
    for file in [
        "bag/bag_0.mcap",
        "bag/metadata.yaml",
        "ground_truth.json",
        "left.yaml",
        "right.yaml",
    ] {
        let expected = std::fs::read(bundled.join(file)).expect("bundled file");
        let actual = std::fs::read(made.join(file)).expect("synthesized file");
        assert!(
            expected == actual,
            "{file} differs from the bundled one: regenerate bags/ with the command in bags/README.md"
        );
    }
}
