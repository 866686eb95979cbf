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
