//! Wavefront material libraries (`.mtl`): what an OBJ's `mtllib` names.
//!
//! Only what [`crate::Material`] holds is read: `newmtl`, `Kd` (the base
//! colour), `d` or `Tr` (alpha) and `map_Kd` (the base-colour texture's file
//! name, options skipped). Everything else (`Ks`, `Ns`, `illum`, bump maps,
//! ...) carries nothing csrbf keeps. A library is a side file of a model,
//! so a bad line never refuses the mesh: it is skipped with a warning
//! naming the library and the line.

use std::path::Path;

use super::text::lines;

/// Most warnings one library adds; a garbage file says how many more.
const MAX_WARNINGS: usize = 8;

/// The base colour MTL gives a material without `Kd`; the same grey the
/// writer gives a material the mesh has no colour for.
pub(crate) const DEFAULT_KD: [f32; 3] = [0.8, 0.8, 0.8];

/// One `newmtl` block as the file gives it.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Entry {
    /// The material's name.
    pub name: String,
    /// `Kd` and alpha (`d`, or 1 - `Tr`), as written: csrbf writes the
    /// linear base colour there (glTF's `baseColorFactor`), so the numbers
    /// go through OBJ and glTF unchanged.
    pub color: [f32; 4],
    /// The `map_Kd` file name as written (`\` made `/`), when there is one.
    pub texture: Option<String>,
}

/// Parses a material library. Bad lines are skipped and said in
/// `warnings`, each naming `path` and the line.
pub(crate) fn parse(bytes: &[u8], path: &Path, warnings: &mut Vec<String>) -> Vec<Entry> {
    let mut out: Vec<Entry> = Vec::new();
    // `d` wins over `Tr` in a block that has both (`Tr` is the older,
    // less agreed-on form).
    let mut alpha_from_d = false;
    let mut said = 0usize;
    let mut warn = |line: Option<usize>, message: String| {
        said += 1;
        if said <= MAX_WARNINGS {
            let at = line.map(|l| format!(":{l}")).unwrap_or_default();
            warnings.push(format!("{}{at}: {message}", path.display()));
        }
    };
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    for item in lines(bytes, path) {
        let (ln, line) = match item {
            Ok(l) => l,
            Err(e) => {
                warn(None, format!("{e}; the line is skipped"));
                continue;
            }
        };
        let mut tok = line.split_ascii_whitespace();
        let Some(key) = tok.next() else { continue };
        let rest = line[key.len()..].trim();
        if key == "newmtl" {
            if rest.is_empty() {
                warn(
                    Some(ln),
                    "newmtl without a name; the line is skipped".into(),
                );
                continue;
            }
            out.push(Entry {
                name: rest.to_owned(),
                color: [DEFAULT_KD[0], DEFAULT_KD[1], DEFAULT_KD[2], 1.0],
                texture: None,
            });
            alpha_from_d = false;
            continue;
        }
        if !matches!(key, "Kd" | "d" | "Tr" | "map_Kd") {
            continue;
        }
        let Some(entry) = out.last_mut() else {
            warn(
                Some(ln),
                format!("{key} before any newmtl; the line is skipped"),
            );
            continue;
        };
        match key {
            "Kd" => match colour(rest) {
                Ok(rgb) => entry.color[..3].copy_from_slice(&rgb),
                Err(m) => warn(Some(ln), format!("Kd {m}; the colour is left grey")),
            },
            "d" | "Tr" => {
                // `d -halo 0.5`: the option changes how, not how much.
                let value = rest.strip_prefix("-halo").unwrap_or(rest).trim();
                match unit(value) {
                    Ok(v) if key == "d" => {
                        entry.color[3] = v;
                        alpha_from_d = true;
                    }
                    Ok(v) if !alpha_from_d => entry.color[3] = 1.0 - v,
                    Ok(_) => {}
                    Err(m) => warn(Some(ln), format!("{key} {m}; the material stays opaque")),
                }
            }
            _ => match texture_name(rest) {
                Some(name) => entry.texture = Some(name),
                None => warn(Some(ln), "map_Kd names no file; the line is skipped".into()),
            },
        }
    }
    if said > MAX_WARNINGS {
        warnings.push(format!(
            "{}: {} more lines like these were skipped",
            path.display(),
            said - MAX_WARNINGS
        ));
    }
    out
}

/// A `Kd` value: `r g b`, or one number for all three (as the format
/// allows); `spectral` and `xyz` forms are not read.
fn colour(rest: &str) -> Result<[f32; 3], String> {
    let vals: Vec<&str> = rest.split_ascii_whitespace().take(4).collect();
    if matches!(vals.first(), Some(&"spectral") | Some(&"xyz")) {
        return Err(format!("{} colours are not read", vals[0]));
    }
    let nums: Vec<f32> = vals
        .iter()
        .take(3)
        .map(|t| finite(t))
        .collect::<Result<_, _>>()?;
    Ok(match nums[..] {
        [v] => [v, v, v],
        [r, g, b] => [r, g, b],
        _ => return Err(format!("{rest:?} needs 1 or 3 numbers")),
    })
}

/// A finite number.
fn finite(t: &str) -> Result<f32, String> {
    t.parse::<f32>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| format!("{t:?} is not a finite number"))
}

/// A number in [0, 1] (clamped when a little outside, refused when not a number).
fn unit(t: &str) -> Result<f32, String> {
    let t = t.split_ascii_whitespace().next().ok_or("needs a number")?;
    Ok(finite(t)?.clamp(0.0, 1.0))
}

/// The file name of a `map_Kd` line: what follows its options (`-o u v w`,
/// `-bm 1`, `-clamp on`, ...), which may hold spaces; `\` is read as `/`.
fn texture_name(rest: &str) -> Option<String> {
    let mut tok: Vec<&str> = rest.split_ascii_whitespace().collect();
    tok.reverse();
    while let Some(t) = tok.last().copied() {
        // How many values each option takes; -o, -s and -t up to three numbers.
        let (min, max) = match t {
            "-blendu" | "-blendv" | "-cc" | "-clamp" | "-bm" | "-boost" | "-texres"
            | "-imfchan" | "-type" => (1, 1),
            "-mm" => (2, 2),
            "-o" | "-s" | "-t" => (1, 3),
            _ => break,
        };
        tok.pop();
        for k in 0..max {
            match tok.last() {
                Some(v) if k < min || v.parse::<f32>().is_ok() => {
                    tok.pop();
                }
                _ => break,
            }
        }
    }
    tok.reverse();
    let name = tok.join(" ").replace('\\', "/");
    (!name.is_empty()).then_some(name)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str) -> (Vec<Entry>, Vec<String>) {
        let mut w = Vec::new();
        let e = parse(text.as_bytes(), Path::new("m.mtl"), &mut w);
        (e, w)
    }

    #[test]
    fn colours_alpha_and_texture_names() {
        let (e, w) = read(
            "# Blender MTL\nnewmtl blinn3\nNs 96\nKd 0.2 0.4 0.6\nd 0.5\nTr 0.9\nmap_Kd -o 0.1 0.2 -bm 1 my tex\\duck.png\n\
newmtl grey\r\nKd 0.25\nTr 0.25\nnewmtl plain\n",
        );
        assert!(w.is_empty(), "{w:?}");
        assert_eq!(e[0].color, [0.2, 0.4, 0.6, 0.5]);
        assert_eq!(e[0].texture.as_deref(), Some("my tex/duck.png"));
        assert_eq!(e[1].color, [0.25, 0.25, 0.25, 0.75]);
        assert_eq!(e[2].color, [0.8, 0.8, 0.8, 1.0]);
        assert_eq!(e[2].texture, None);
    }

    #[test]
    fn bad_lines_are_skipped_with_their_line_named() {
        let mut text = String::from("Kd 1 0 0\nnewmtl a\nKd 1 nan 0\nd x\nmap_Kd -clamp on\n");
        for _ in 0..20 {
            text.push_str("Kd spectral f.rfl\n");
        }
        text.push_str("newmtl b\nKd 0 1 0\n");
        let (e, w) = read(&text);
        assert_eq!(e.len(), 2);
        assert_eq!(e[0].color, [0.8, 0.8, 0.8, 1.0]);
        assert_eq!(e[1].color, [0.0, 1.0, 0.0, 1.0]);
        assert!(w[0].starts_with("m.mtl:1: Kd before any newmtl"), "{w:?}");
        assert!(w[1].starts_with("m.mtl:3: Kd"), "{w:?}");
        assert!(w[3].starts_with("m.mtl:5: map_Kd names no file"), "{w:?}");
        assert_eq!(w.len(), MAX_WARNINGS + 1, "{w:?}");
        assert!(w[MAX_WARNINGS].contains("more lines"), "{w:?}");
    }
}
