//! What serde_json lets pass in a hand-written JSON file and a user would
//! not want: a byte-order mark (accepted), and a key written twice in one
//! object (refused: serde_json keeps the last silently).

use std::collections::HashMap;

/// A key given twice in one object.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error(
    "key {key:?} is given twice in one object, at line {first_line} and at line {second_line}; keep one"
)]
pub struct DuplicateKey {
    /// The key.
    pub key: String,
    /// Where it is first.
    pub first_line: usize,
    /// Where it is again.
    pub second_line: usize,
}

/// serde_json's message for `e` without the place it ends with (" at line
/// L column C"), for a caller that says the place itself, once.
pub fn message_without_place(e: &serde_json::Error) -> String {
    let message = e.to_string();
    let suffix = format!(" at line {} column {}", e.line(), e.column());
    message.strip_suffix(&suffix).unwrap_or(&message).to_owned()
}

/// The text without a leading UTF-8 byte-order mark.
pub fn strip_bom(text: &str) -> &str {
    text.strip_prefix('\u{feff}').unwrap_or(text)
}

/// Finds the first key written twice in one object of a JSON text (the
/// text's syntax is left to the parser: this only looks at keys).
pub fn check_duplicate_keys(text: &str) -> Result<(), DuplicateKey> {
    enum Frame {
        Object {
            keys: HashMap<String, usize>,
            expect_key: bool,
        },
        Array,
    }
    let mut stack: Vec<Frame> = Vec::new();
    let mut line = 1usize;
    let mut chars = text.char_indices().peekable();
    while let Some((_, c)) = chars.next() {
        match c {
            '\n' => line += 1,
            '{' => stack.push(Frame::Object {
                keys: HashMap::new(),
                expect_key: true,
            }),
            '[' => stack.push(Frame::Array),
            '}' | ']' => {
                stack.pop();
            }
            ',' => {
                if let Some(Frame::Object { expect_key, .. }) = stack.last_mut() {
                    *expect_key = true;
                }
            }
            ':' => {
                if let Some(Frame::Object { expect_key, .. }) = stack.last_mut() {
                    *expect_key = false;
                }
            }
            '"' => {
                let start_line = line;
                let mut s = String::new();
                while let Some((_, c)) = chars.next() {
                    match c {
                        '\\' => {
                            if let Some((_, e)) = chars.next() {
                                s.push('\\');
                                s.push(e);
                            }
                        }
                        '"' => break,
                        '\n' => {
                            line += 1;
                            s.push(c);
                        }
                        _ => s.push(c),
                    }
                }
                if let Some(Frame::Object { keys, expect_key }) = stack.last_mut()
                    && *expect_key
                {
                    if let Some(&first_line) = keys.get(&s) {
                        return Err(DuplicateKey {
                            key: s,
                            first_line,
                            second_line: start_line,
                        });
                    }
                    keys.insert(s, start_line);
                }
            }
            _ => {}
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn duplicates_are_found_with_both_lines_and_nothing_else_is() {
        let e = check_duplicate_keys("{\n \"radius\": 3.5,\n \"radius\": 0.1\n}").expect_err("dup");
        assert_eq!(
            (e.key.as_str(), e.first_line, e.second_line),
            ("radius", 2, 3)
        );
        // The same key in different objects, keys in strings, arrays of objects: fine.
        assert!(
            check_duplicate_keys(
                r#"{"a": {"x": 1}, "b": {"x": 2}, "c": [{"x": 1}, {"x": 2}], "d": "x\"x"}"#
            )
            .is_ok()
        );
        assert!(check_duplicate_keys(r#"{"a": [1, {"k": 1, "j": 2}], "a2": 1}"#).is_ok());
        assert!(check_duplicate_keys(r#"[{"k": 1}, {"k": 1, "k": 2}]"#).is_err());
        assert_eq!(strip_bom("\u{feff}{}"), "{}");
    }
}
