//! The Mitsuba importer's tests: what each plugin becomes, and mangled files.

use super::*;
use proptest::prelude::*;

const CORNELL: &str = include_str!("../../../../scenes/mitsuba/cornell_box.xml");

proptest! {
    #![proptest_config(proptest::test_runner::Config::with_cases(300))]
    /// The shipped XML scene cut short, or with a piece cut out or replaced by a token:
    /// an error, or RON that the loader takes or refuses, never a panic.
    #[test]
    fn mangled_xml_never_panics(
        at in any::<proptest::sample::Index>(),
        len in 0usize..40,
        token in prop::sample::select(vec![
            "", "<", ">", "/>", "\"", "$", "$spp", "type=\"cube\"", "<ref id=\"white\"/>",
            "<transform name=\"to_world\">", "value=\"1e39\"", "NaN", "-1", "&amp;", "<!--",
        ]),
    ) {
        let mut start = at.index(CORNELL.len() + 1);
        while !CORNELL.is_char_boundary(start) {
            start -= 1;
        }
        let mut end = (start + len).min(CORNELL.len());
        while !CORNELL.is_char_boundary(end) {
            end -= 1;
        }
        let text = if len == 0 {
            CORNELL[..start].to_string()
        } else {
            format!("{}{token}{}", &CORNELL[..start], &CORNELL[end..])
        };
        if let Ok(imported) = to_ron(&text, &[]) {
            let _ = crate::scene::parse_scene(&imported.ron().unwrap(), std::path::Path::new("mangled.xml"));
        }
    }
}

#[test]
fn the_ron_names_what_the_xml_names() {
    let imported = to_ron(CORNELL, &[("spp".into(), "9".into())]).unwrap();
    for needle in [
        "\"white\": Lambert(albedo: (0.885809, 0.698859, 0.666422))",
        "(name: \"small-box\", transform: (matrix: [",
        "shape: Box(min: (-1.0, -1.0, -1.0), max: (1.0, 1.0, 1.0)), material: \"white\"",
        "emitter: Area(radiance: (18.387, 13.9873, 6.75357), two_sided: false)",
        "spp: 9,",
        "filter: \"gaussian\"",
        "\"max-depth\": 7.0",
    ] {
        assert!(
            imported.ron().unwrap().contains(needle),
            "no {needle} in\n{}",
            imported.ron().unwrap()
        );
    }
}
