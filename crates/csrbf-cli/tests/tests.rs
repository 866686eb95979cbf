//! The `csrbf` binary on real models and on every bad input the issue lists.

mod aim;
mod bad_input;
mod commands;
mod connected;
mod docs;
mod intersections;
mod limits;
mod meaning;
mod pictures;
mod road;
mod side_files;
mod stretch;
mod support;
mod volume;
