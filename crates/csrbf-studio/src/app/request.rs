//! What a room asks of the shell: the Picker's and the Composer's panels,
//! viewports and keys own their documents, and ask for what only the shell
//! can do (a file dialog, an error shown in a modal, opening or saving a
//! file in the other room) by leaving a [`Request`] in their
//! outbox, which the shell reads after each of their calls.

use super::files::Purpose;

/// One thing a room asks of the shell.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Request {
    /// A file dialog for this purpose.
    Ask(Purpose),
    /// An error shown in a modal (and the status line): a title and the
    /// reason.
    Error { title: String, text: String },
    /// Deformation `.2` of part `.1` of object `.0` edited in the Picker.
    EditInPicker(usize, usize, usize),
}

/// A room's requests, in the order it made them.
#[derive(Debug, Default)]
pub(super) struct Outbox(Vec<Request>);

impl Outbox {
    /// Asks for `request`.
    pub(super) fn push(&mut self, request: Request) {
        self.0.push(request);
    }

    /// An error to show: `title` and the reason.
    pub(super) fn error(&mut self, title: impl Into<String>, text: impl ToString) {
        self.0.push(Request::Error {
            title: title.into(),
            text: text.to_string(),
        });
    }

    /// The requests made so far, leaving the outbox empty.
    pub(super) fn take(&mut self) -> Vec<Request> {
        std::mem::take(&mut self.0)
    }
}

/// An error and its sources as one line, as the CLI prints them: "x.obj: No
/// such file or directory (os error 2)", where `to_string` would keep only
/// "x.obj" (the edit layer's `error_chain`, every front end's).
pub(super) fn reason(e: &dyn std::error::Error) -> String {
    csrbf_edit::error_chain(e)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_reason_keeps_the_systems_error_once() {
        let missing = std::path::Path::new("/no/such/dir/x.obj");
        let e = csrbf_mesh::read(missing).expect_err("no such file");
        let text = reason(&e);
        assert!(
            text.starts_with("cannot read mesh /no/such/dir/x.obj: "),
            "{text}"
        );
        let os = std::io::Error::from(std::io::ErrorKind::NotFound).to_string();
        assert!(
            text.contains("No such file") || text.contains(&os),
            "{text}"
        );
        // An error whose message already holds its source says it once.
        let parse = csrbf_edit::controls::ControlFile::parse("{").expect_err("broken");
        let text = reason(&parse);
        assert_eq!(text.matches(&parse.to_string()).count(), 1, "{text}");
    }
}
