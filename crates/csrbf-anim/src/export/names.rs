//! Morph target names: what a user reads as a shape key's name.

use crate::scene::Animated;

/// The longest name Blender keeps (it cuts names at 63 bytes).
pub const MAX_NAME_BYTES: usize = 63;

/// The names of an object's morph targets, in the order the exporter writes
/// them (a chained file is one target, an added file one per deformation):
/// the deformation's `name` in its control file, else the control file's
/// stem (with `.K` after it for the K-th of several unnamed deformations),
/// cut to [`MAX_NAME_BYTES`] and made unique within the mesh (` 2`, ` 3`).
pub fn target_names(
    deformations: &[Animated],
    one_per_file: impl Fn(&Animated) -> bool,
) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    for anim in deformations {
        let stem = file_stem(&anim.controls);
        if one_per_file(anim) {
            let only_name = match anim.stages.as_slice() {
                [one] => one.name.clone(),
                _ => None,
            };
            names.push(unique(&names, only_name.unwrap_or(stem)));
            continue;
        }
        let several = anim.stages.len() > 1;
        for (si, st) in anim.stages.iter().enumerate() {
            let given = st.name.as_deref().map(str::trim).filter(|n| !n.is_empty());
            let name = match (given, st.sweep) {
                // A sweep's steps: `name step 3/8`, the step last so a cut
                // keeps the name's start.
                (n, Some(s)) => format!(
                    "{} step {}/{}",
                    cut(n.unwrap_or(&stem), MAX_NAME_BYTES - 16),
                    s.index + 1,
                    s.count
                ),
                (Some(n), None) => n.to_owned(),
                (None, None) if several => format!("{stem}.{si}"),
                (None, None) => stem.clone(),
            };
            names.push(unique(&names, name));
        }
    }
    names
}

/// The file name of a path as a scene spells it (either separator), without
/// its extension.
fn file_stem(path: &str) -> String {
    let file = path.rsplit(['/', '\\']).next().unwrap_or(path);
    let stem = match file.rsplit_once('.') {
        Some((s, _)) if !s.is_empty() => s,
        _ => file,
    };
    if stem.is_empty() {
        "deformation".into()
    } else {
        stem.into()
    }
}

/// `name` cut to the byte limit (on a character boundary), with ` K` added
/// when an earlier name is the same.
fn unique(taken: &[String], name: String) -> String {
    let base = cut(&name, MAX_NAME_BYTES);
    if !taken.contains(&base) {
        return base;
    }
    (2..)
        .map(|k| {
            let suffix = format!(" {k}");
            format!("{}{suffix}", cut(&name, MAX_NAME_BYTES - suffix.len()))
        })
        .find(|n| !taken.contains(n))
        .unwrap_or(base)
}

fn cut(s: &str, bytes: usize) -> String {
    let mut end = s.len().min(bytes);
    while !s.is_char_boundary(end) {
        end -= 1;
    }
    s[..end].to_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_short_unique_stems() {
        assert_eq!(file_stem("../a/long_folder_name/expr.json"), "expr");
        assert_eq!(file_stem("C:\\x\\smile.v2.json"), "smile.v2");
        assert_eq!(file_stem(".json"), ".json");
        let taken = vec!["smile".to_owned()];
        assert_eq!(unique(&taken, "smile".into()), "smile 2");
        let long = "é".repeat(40);
        let a = unique(&[], long.clone());
        assert!(a.len() <= MAX_NAME_BYTES && a.len() == 62, "{}", a.len());
        let b = unique(std::slice::from_ref(&a), long);
        assert!(b.len() <= MAX_NAME_BYTES && b.ends_with(" 2") && b != a);
    }
}
