//! `<include filename="...">` and `<path value="...">`: the scene's text with each include
//! replaced by the content of the included file's `<scene>` (recursively), and a map from
//! places in that text back to the file and line each came from, so that an error in an
//! included file names that file.

use crate::formats::access::SceneFiles;
use roxmltree::{Document, Node};
use std::path::{Path, PathBuf};

/// Includes nested deeper than this are refused.
const MAX_DEPTH: usize = 16;
/// The most text all includes together may add.
const MAX_BYTES: usize = 4 * crate::files::MAX_TEXT as usize;
/// The most includes a scene may make, all files together (as the pbrt importer's): a file
/// that includes the next ten times, sixteen deep, would otherwise ask for 10^15.
pub const MAX_INCLUDES: usize = 10_000;
/// Elements nested deeper than this are refused, in the scene and in every included file (the
/// converter walks nested plugins recursively; Mitsuba's own scenes nest a handful deep).
pub const MAX_NESTING: usize = 64;

/// Refuses a document whose elements nest deeper than [`MAX_NESTING`]: the element at fault
/// and its place.
pub fn check_nesting(doc: &Document) -> Result<(), (u32, u32, String)> {
    // Each node's depth from its parent's, in document order (parents come first).
    let mut depth = vec![0usize; doc.descendants().count()];
    for node in doc.descendants().filter(Node::is_element) {
        let d = node.parent().map_or(0, |p| depth[p.id().get() as usize]) + 1;
        depth[node.id().get() as usize] = d;
        if d > MAX_NESTING {
            let p = doc.text_pos_at(node.range().start);
            return Err((
                p.row,
                p.col,
                format!("elements nest deeper than {MAX_NESTING}"),
            ));
        }
    }
    Ok(())
}

/// An error at a file's line and column.
pub type FileError = (PathBuf, u32, u32, String);

/// A piece of the expanded text copied from one file.
struct Segment {
    start: usize,
    file: usize,
    source_start: usize,
}

/// The scene's text with its includes expanded.
pub struct Expanded {
    pub text: String,
    /// The `<path>` folders, in order, relative to the scene's folder.
    pub search: Vec<String>,
    segments: Vec<Segment>,
    files: Vec<(PathBuf, String)>,
}

fn line_col(text: &str, offset: usize) -> (u32, u32) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() as u32 + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) as u32 + 1;
    (line, col)
}

fn offset_of(text: &str, line: u32, col: u32) -> usize {
    let mut offset = 0;
    for (i, l) in text.split_inclusive('\n').enumerate() {
        if i + 1 == line as usize {
            return offset
                + l.char_indices()
                    .nth(col.saturating_sub(1) as usize)
                    .map_or(l.len(), |(b, _)| b);
        }
        offset += l.len();
    }
    text.len()
}

impl Expanded {
    /// The file, line and column of the expanded text's `line` and `col`.
    pub fn locate(&self, line: u32, col: u32) -> (PathBuf, u32, u32) {
        let offset = offset_of(&self.text, line, col);
        let i = self
            .segments
            .partition_point(|s| s.start <= offset)
            .saturating_sub(1);
        match self.segments.get(i) {
            Some(s) => {
                let (path, text) = &self.files[s.file];
                let (l, c) = line_col(text, s.source_start + (offset - s.start));
                (path.clone(), l, c)
            }
            None => (self.files[0].0.clone(), line, col),
        }
    }
}

struct Expander<'f> {
    files: &'f SceneFiles,
    out: Expanded,
    stack: Vec<PathBuf>,
    /// Includes made so far, all files together.
    includes: usize,
    /// Whether the scene file is Mitsuba 0.x's (read through the upgrade rules).
    legacy: bool,
}

/// The text of `path` with its includes expanded.
pub fn expand(path: &Path, text: &str, files: &SceneFiles) -> Result<Expanded, FileError> {
    let mut e = Expander {
        files,
        out: Expanded {
            text: String::with_capacity(text.len()),
            search: Vec::new(),
            segments: Vec::new(),
            files: Vec::new(),
        },
        stack: vec![path.canonicalize().unwrap_or_else(|_| path.to_path_buf())],
        includes: 0,
        legacy: false,
    };
    e.file(path, text.to_string(), None)?;
    Ok(e.out)
}

impl Expander<'_> {
    fn copy(&mut self, file: usize, range: std::ops::Range<usize>) {
        let text = &self.out.files[file].1[range.clone()];
        self.out.segments.push(Segment {
            start: self.out.text.len(),
            file,
            source_start: range.start,
        });
        self.out.text.push_str(text);
    }

    /// Copies `text` (of `path`): the whole of it for the scene, the content of its
    /// `<scene>` for an included file.
    fn file(
        &mut self,
        path: &Path,
        text: String,
        included_at: Option<FileError>,
    ) -> Result<(), FileError> {
        let index = self.out.files.len();
        self.out.files.push((path.to_path_buf(), text));
        let text = self.out.files[index].1.clone();
        super::xml::check_attributes(&text).map_err(|(l, c, m)| (path.to_path_buf(), l, c, m))?;
        let doc = match Document::parse(&text) {
            Ok(doc) => doc,
            // Left to the converter, which reports it at its place.
            Err(_) if included_at.is_none() => {
                self.copy(index, 0..text.len());
                return Ok(());
            }
            Err(e) => {
                let p = e.pos();
                return Err((
                    path.to_path_buf(),
                    p.row,
                    p.col,
                    format!("malformed XML: {e}"),
                ));
            }
        };
        check_nesting(&doc).map_err(|(line, col, m)| (path.to_path_buf(), line, col, m))?;
        let at = |node: Node, message: String| -> FileError {
            let p = doc.text_pos_at(node.range().start);
            (path.to_path_buf(), p.row, p.col, message)
        };
        let root = doc.root_element();
        // The upgrade from Mitsuba 0.x applies to the whole expanded text: an included file
        // must be of the same generation as the scene.
        let legacy = super::xml::major_version(&doc, root)
            .map_err(|(l, c, m)| (path.to_path_buf(), l, c, m))?
            .is_some_and(|major| major < 2);
        if included_at.is_none() {
            self.legacy = legacy;
        } else if legacy != self.legacy {
            return Err(at(
                root,
                format!(
                    "an included file of Mitsuba {} in a scene of Mitsuba {}: give both the same major version",
                    if legacy { "0.x" } else { "2 or 3" },
                    if self.legacy { "0.x" } else { "2 or 3" }
                ),
            ));
        }
        let range = if included_at.is_some() {
            if root.tag_name().name() != "scene" {
                return Err(at(
                    root,
                    format!(
                        "an included file holds a <scene>, not a <{}>",
                        root.tag_name().name()
                    ),
                ));
            }
            match (root.first_child(), root.last_child()) {
                (Some(first), Some(last)) => first.range().start..last.range().end,
                _ => return Ok(()),
            }
        } else {
            0..text.len()
        };
        let mut cursor = range.start;
        for node in root.children().filter(Node::is_element) {
            match node.tag_name().name() {
                "path" => {
                    let value = node
                        .attribute("value")
                        .ok_or_else(|| at(node, "<path> needs a `value`".into()))?;
                    self.out.search.push(value.to_string());
                }
                "include" => {
                    let name = node
                        .attribute("filename")
                        .ok_or_else(|| at(node, "<include> needs a `filename`".into()))?;
                    let r = node.range();
                    self.copy(index, cursor..r.start);
                    cursor = r.end;
                    self.include(node, name, &at)?;
                }
                _ => {}
            }
        }
        self.copy(index, cursor..range.end);
        Ok(())
    }

    fn include(
        &mut self,
        node: Node,
        name: &str,
        at: &dyn Fn(Node, String) -> FileError,
    ) -> Result<(), FileError> {
        if self.stack.len() > MAX_DEPTH {
            return Err(at(
                node,
                format!("<include>: includes nest deeper than {MAX_DEPTH}"),
            ));
        }
        self.includes += 1;
        if self.includes > MAX_INCLUDES {
            return Err(at(
                node,
                format!("<include>: the scene makes more than {MAX_INCLUDES} includes"),
            ));
        }
        // The scene's folder first, then the <path> folders.
        let candidates = std::iter::once(name.to_string())
            .chain(self.out.search.iter().map(|dir| format!("{dir}/{name}")));
        let mut found = None;
        for candidate in candidates {
            let file = self.files.named(&candidate).map_err(|e| at(node, e))?;
            // Anything there (a folder or a pipe too): reading it says what is wrong with it.
            if file.exists() {
                found = Some(file);
                break;
            }
        }
        let file = found.ok_or_else(|| at(node, format!("<include filename=\"{name}\">: no such file in the scene's folder or its <path> folders")))?;
        let real = file.canonicalize().unwrap_or_else(|_| file.clone());
        if self.stack.contains(&real) {
            return Err(at(
                node,
                format!(
                    "<include filename=\"{name}\">: the file includes itself (a cycle of includes)"
                ),
            ));
        }
        let text = crate::files::read_text_capped(&file, crate::files::MAX_TEXT).map_err(|e| {
            at(
                node,
                format!(
                    "<include filename=\"{name}\">: cannot read `{}`: {e}",
                    file.display()
                ),
            )
        })?;
        if self.out.text.len() + text.len() > MAX_BYTES {
            return Err(at(
                node,
                format!(
                    "<include>: the includes hold more than {} MB of text",
                    MAX_BYTES >> 20
                ),
            ));
        }
        self.stack.push(real);
        let here = at(node, String::new());
        self.file(&file, text, Some(here))?;
        self.stack.pop();
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn includes_are_spliced_and_places_map_back() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("parts")).unwrap();
        std::fs::write(
            dir.path().join("parts/ball.xml"),
            "<scene version=\"3.0.0\">\n  <shape type=\"sphere\"/>\n  <bogus/>\n</scene>\n",
        )
        .unwrap();
        let main = dir.path().join("main.xml");
        let text = "<scene version=\"3.0.0\">\n<path value=\"parts\"/>\n<include filename=\"ball.xml\"/>\n<sensor/>\n</scene>\n";
        std::fs::write(&main, text).unwrap();
        let files = SceneFiles::new(&main, &[]);
        let e = expand(&main, text, &files).unwrap();
        assert_eq!(e.search, vec!["parts".to_string()]);
        assert!(e.text.contains("<shape type=\"sphere\"/>") && !e.text.contains("<include"));
        // The expanded text's <bogus/> is line 3 column 3 of ball.xml; <sensor/> line 4 of main.
        let doc = Document::parse(&e.text).unwrap();
        let pos = |tag: &str| {
            let n = doc
                .descendants()
                .find(|n| n.tag_name().name() == tag)
                .unwrap();
            let p = doc.text_pos_at(n.range().start);
            e.locate(p.row, p.col)
        };
        assert_eq!(pos("bogus"), (dir.path().join("parts/ball.xml"), 3, 3));
        assert_eq!(pos("sensor"), (main.clone(), 4, 1));
    }

    #[test]
    fn cycles_and_missing_files_are_located() {
        let dir = tempfile::tempdir().unwrap();
        let main = dir.path().join("loop.xml");
        let text = "<scene version=\"3.0.0\">\n  <include filename=\"loop.xml\"/>\n</scene>\n";
        std::fs::write(&main, text).unwrap();
        let files = SceneFiles::new(&main, &[]);
        let err = expand(&main, text, &files).err().unwrap();
        assert_eq!((err.1, err.2), (2, 3));
        assert!(err.3.contains("includes itself"), "{}", err.3);
        let text = "<scene version=\"3.0.0\">\n  <include filename=\"nowhere.xml\"/>\n</scene>\n";
        let err = expand(&main, text, &files).err().unwrap();
        assert!(err.3.contains("no such file"), "{}", err.3);
    }
}
