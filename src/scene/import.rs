//! What the importers of other renderers' scenes share: how they are asked (`-D`,
//! `--approximate`), what they give back, and the RON text they write.

use glam::Affine3A;
use std::fmt::Write as _;

/// How a scene of another format is read.
#[derive(Clone, Debug, Default)]
pub struct ImportOptions {
    /// A Mitsuba scene's `<default>` parameters, as `-D NAME=VALUE` sets them.
    pub defines: Vec<(String, String)>,
    /// Replace what raylab does not have by the nearest thing it has, and say so in the
    /// warnings and the report, instead of refusing the scene.
    pub approximate: bool,
}

/// A scene of another format as RON text, with what the conversion did.
#[derive(Debug)]
pub struct Imported {
    pub ron: String,
    /// One line per mapping that is not one to one (an approximation, a changed convention),
    /// as `what: how`.
    pub report: Vec<String>,
    /// The lines of the report that are approximations (`--approximate`), to warn about.
    pub approximated: Vec<String>,
}

/// A number as RON reads it back exactly.
pub fn num(v: f32) -> String {
    format!("{v:?}")
}

/// A 3-vector as RON: `(x, y, z)`.
pub fn v3(v: [f32; 3]) -> String {
    format!("({}, {}, {})", num(v[0]), num(v[1]), num(v[2]))
}

/// A RON string literal.
pub fn quote(s: &str) -> String {
    let mut out = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            c if c.is_control() => {
                let _ = write!(out, "\\u{{{:x}}}", c as u32);
            }
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// The matrix as RON's `transform: (matrix: [...])`, row by row.
pub fn matrix(m: &Affine3A) -> String {
    let rows: Vec<String> = (0..3)
        .flat_map(|r| {
            let row = m.matrix3.row(r);
            [row.x, row.y, row.z, m.translation[r]]
        })
        .map(num)
        .collect();
    format!("(matrix: [{}])", rows.join(", "))
}
