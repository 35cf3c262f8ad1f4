//! Parsing a RON scene file and spawning its entities into a hecs world.

use super::error::SceneError;
use super::inputs::SceneInputs;
use super::LoadedScene;
use crate::formats::access::SceneFiles;
use crate::formats::import::{ImportOptions, Imported, Origins};
use crate::formats::schema::SceneFile;
use ron::extensions::Extensions;
use std::path::{Path, PathBuf};

/// Reads, parses, spawns, validates and bakes a scene file, which may read files under its
/// own folder only.
pub fn load_scene(path: &Path) -> Result<LoadedScene, SceneError> {
    load_scene_with(path, &[])
}

/// [`load_scene`] for a scene that may also read files under the folders `allowed`
/// (`--allow-path`).
pub fn load_scene_with(path: &Path, allowed: &[PathBuf]) -> Result<LoadedScene, SceneError> {
    load_scene_defined(path, allowed, &ImportOptions::default())
}

/// [`load_scene_with`] for any scene format: RON, or a Mitsuba 3 XML or pbrt-v4 scene read
/// with `options` (`-D` parameters for a Mitsuba scene's `<default>`s, `--approximate`).
pub fn load_scene_defined(
    path: &Path,
    allowed: &[PathBuf],
    options: &ImportOptions,
) -> Result<LoadedScene, SceneError> {
    load_scene_in(&SceneFiles::new(path, &options.readable(allowed)), options)
}

/// Loads the scene of `files` (which keeps the list of what it read, also when the load
/// fails), read with `options`.
pub fn load_scene_in(
    files: &SceneFiles,
    options: &ImportOptions,
) -> Result<LoadedScene, SceneError> {
    let (file, approximated, origins) = read_scene_file_with_origins(files, options)?;
    world_of(file, approximated, &origins, files, options)
}

/// The world of a scene `imported` (by [`import_scene`] from the scene of `files`), as
/// [`load_scene_in`] would load it, without importing it again.
pub fn load_imported(
    imported: &Imported,
    files: &SceneFiles,
    options: &ImportOptions,
) -> Result<LoadedScene, SceneError> {
    world_of(
        imported.scene.clone(),
        approximation_warnings(&imported.approximated),
        &imported.origins,
        files,
        options,
    )
}

/// A scene description made into a world; an error about an imported entity or material
/// names the place it came from (`origins`).
fn world_of(
    file: SceneFile,
    warnings: Vec<String>,
    origins: &Origins,
    files: &SceneFiles,
    options: &ImportOptions,
) -> Result<LoadedScene, SceneError> {
    let mut loaded =
        super::edit::build_world(file, files.scene(), files).map_err(|e| origins.place(e))?;
    loaded.warnings.extend(warnings);
    loaded.warnings.extend(files.take_notes());
    loaded.inputs = SceneInputs::of(files, options);
    Ok(loaded)
}

/// The `--approximate` warnings of an import.
fn approximation_warnings(approximated: &[String]) -> Vec<String> {
    approximated
        .iter()
        .map(|a| format!("--approximate: {a}"))
        .collect()
}

/// Reads and parses the scene file of `files` in any format (as [`load_scene_defined`]),
/// without making a world of it; also the `--approximate` warnings of an imported scene.
pub fn read_scene_file(
    files: &SceneFiles,
    options: &ImportOptions,
) -> Result<(SceneFile, Vec<String>), SceneError> {
    read_scene_file_with_origins(files, options).map(|(file, warnings, _)| (file, warnings))
}

/// [`read_scene_file`], with where an imported scene's entities and materials came from.
pub fn read_scene_file_with_origins(
    files: &SceneFiles,
    options: &ImportOptions,
) -> Result<(SceneFile, Vec<String>, Origins), SceneError> {
    let path = files.scene();
    if let Some(imported) = import_scene(files, options)? {
        let warnings = approximation_warnings(&imported.approximated);
        return Ok((imported.scene, warnings, imported.origins));
    }
    let text = read_scene_text(path)?;
    // What parsing holds at its peak, checked before it starts (the entities' memory is
    // checked again, by count, before they are made).
    super::systems::check_bytes(
        (text.len() as u64).saturating_mul(RON_BYTES_PER_BYTE),
        &format!("{} MB of RON text", text.len() >> 20),
    )
    .map_err(|message| SceneError::Scene {
        path: path.to_path_buf(),
        message,
    })?;
    let file = parse_scene_file(&text, path)?;
    Ok((file, Vec::new(), Origins::default()))
}

/// Whether `path` names a Mitsuba 3 XML scene (by its extension).
pub fn is_mitsuba(path: &Path) -> bool {
    has_extension(path, "xml")
}

/// Whether `path` names a pbrt-v4 scene (by its extension: `.pbrt`, or `.pbrt.gz`).
pub fn is_pbrt(path: &Path) -> bool {
    has_extension(path, "pbrt")
        || (has_extension(path, "gz") && has_extension(&path.with_extension(""), "pbrt"))
}

/// Whether `path` names a scene of another renderer, which raylab imports into RON.
pub fn is_imported(path: &Path) -> bool {
    is_mitsuba(path) || is_pbrt(path)
}

fn has_extension(path: &Path, ext: &str) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case(ext))
}

fn read_scene_text(path: &Path) -> Result<String, SceneError> {
    crate::files::read_text_capped(path, crate::files::MAX_TEXT).map_err(|reason| {
        SceneError::Read {
            path: path.to_path_buf(),
            reason,
        }
    })
}

/// A Mitsuba 3 XML or pbrt-v4 scene converted into RON; `None` for a RON scene (which takes
/// no import options).
pub fn import_scene(
    files: &SceneFiles,
    options: &ImportOptions,
) -> Result<Option<Imported>, SceneError> {
    let path = files.scene();
    if !is_imported(path) {
        let refused = match (options.defines.first(), options.approximate) {
            _ if !options.search.is_empty() => Some(
                "-a DIR searches for the files a Mitsuba XML scene names; this is a RON scene"
                    .into(),
            ),
            (Some((name, _)), _) => Some(format!(
                "-D {name}=... sets a Mitsuba XML scene's <default>; this is a RON scene"
            )),
            (None, true) => Some(
                "--approximate is for Mitsuba XML and pbrt-v4 scenes; this is a RON scene".into(),
            ),
            (None, false) => None,
        };
        return match refused {
            Some(message) => Err(SceneError::Scene {
                path: path.to_path_buf(),
                message,
            }),
            None => Ok(None),
        };
    }
    let text = read_scene_text(path)?;
    if is_mitsuba(path) {
        let located = |(file, line, col, message): (PathBuf, u32, u32, String)| SceneError::Parse {
            path: file,
            line: line as usize,
            col: col as usize,
            message,
        };
        let expanded =
            crate::formats::mitsuba::include::expand(path, &text, files).map_err(located)?;
        // Its <path> folders, then the search folders given (`-a`).
        let search: Vec<String> = expanded
            .search
            .iter()
            .cloned()
            .chain(
                options
                    .search
                    .iter()
                    .map(|d| d.to_string_lossy().into_owned()),
            )
            .collect();
        let mut imported =
            crate::formats::mitsuba::to_ron_in(&expanded.text, options, Some(files), &search)
                .map_err(|(line, col, message)| {
                    let (file, line, col) = expanded.locate(line, col);
                    located((file, line, col, message))
                })?;
        for place in imported
            .origins
            .entities
            .values_mut()
            .chain(imported.origins.materials.values_mut())
        {
            *place = expanded.locate(place.1, place.2);
        }
        return Ok(Some(imported));
    }
    if let Some((name, _)) = options.defines.first() {
        return Err(SceneError::Scene {
            path: path.to_path_buf(),
            message: format!(
                "-D {name}=... sets a Mitsuba XML scene's <default>; this is a pbrt-v4 scene"
            ),
        });
    }
    if !options.search.is_empty() {
        return Err(SceneError::Scene {
            path: path.to_path_buf(),
            message: "-a DIR searches for the files a Mitsuba XML scene names; this is a pbrt-v4 \
                      scene (its Include and file names are relative to its folder)"
                .into(),
        });
    }
    crate::formats::pbrt::to_ron(path, &text, files, options)
        .map(Some)
        .map_err(|(file, line, col, message)| SceneError::Parse {
            path: file,
            line: line as usize,
            col: col as usize,
            message,
        })
}

/// Parses scene text; `path` is used in messages and to resolve relative files (under its
/// folder).
pub fn parse_scene(text: &str, path: &Path) -> Result<LoadedScene, SceneError> {
    let files = SceneFiles::new(path, &[]);
    let mut loaded = super::edit::build_world(parse_scene_file(text, path)?, path, &files)?;
    loaded.inputs = SceneInputs::of(&files, &ImportOptions::default());
    Ok(loaded)
}

/// Parses scene text into its schema, without loading any file it names or checking values;
/// `path` is used in messages.
pub fn parse_scene_file(text: &str, path: &Path) -> Result<SceneFile, SceneError> {
    let options = ron::Options::default()
        .with_default_extension(Extensions::IMPLICIT_SOME)
        .with_recursion_limit(MAX_RON_NESTING);
    let file: SceneFile = options.from_str(text).map_err(|e| {
        let (line, col) = (e.span.start.line, e.span.start.col);
        let mut message = match e.code {
            ron::Error::ExceededRecursionLimit => {
                format!("values nest deeper than {MAX_RON_NESTING} here")
            }
            code => code.to_string(),
        };
        // The error's span reaches the end of the text: it ran out of text.
        if (e.span.end.line, e.span.end.col) >= end_position(text) {
            message.push_str("; the file ends here: is it truncated?");
        }
        SceneError::Parse {
            path: path.to_path_buf(),
            line,
            col,
            message,
        }
    })?;
    Ok(file)
}

/// Memory parsing a byte of RON text takes at its peak (the text, its parse and the scene
/// description): measured about 11 for 2 million spheres in 54 MB.
const RON_BYTES_PER_BYTE: u64 = 16;

/// How deep RON values may nest (materials inside materials: an imported scene's BSDFs nest
/// at most 64 deep, two levels each).
const MAX_RON_NESTING: usize = 256;

/// Line and column (as ron counts them: from 1, in characters) just after the last
/// non-whitespace character of `text`.
fn end_position(text: &str) -> (usize, usize) {
    let text = text.trim_end();
    let line = 1 + text.matches('\n').count();
    let col = 1 + text.chars().rev().take_while(|&c| c != '\n').count();
    (line, col)
}
