//! The engine's errors: each says what was wrong and where.

/// Everything that can go wrong in the engine. The kinds a caller would
/// tell apart are enums of their own, each with the variant that says what
/// was wrong and where: [`FitError`] (starts, destinations and options that
/// make no map), [`NameError`] (a kernel, polynomial, solver, ordering or
/// combine name), [`FormatError`] (a `.csrbf` file), [`RegionError`].
/// Fitting calls ([`crate::System::new`], [`crate::System::solve`],
/// [`crate::Deformation::fit`]) return [`FitError`] itself.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum Error {
    /// The control vectors or options cannot be fitted.
    #[error(transparent)]
    Fit(#[from] FitError),
    /// A name that is not one of the choices.
    #[error(transparent)]
    Name(#[from] NameError),
    /// A `.csrbf` file that cannot be read.
    #[error(transparent)]
    Format(#[from] FormatError),
    /// A region that cannot be used.
    #[error(transparent)]
    Region(#[from] RegionError),
    /// A handle that cannot make control vectors (its message says why).
    #[error("handle: {0}")]
    BadHandle(String),
    /// The phase is outside [0, 1].
    #[error("phase must be within [0, 1], got {0}")]
    BadPhase(f64),
    /// A stretch limit that is not a finite number >= 1.
    #[error("stretch limit must be a finite number >= 1, got {0}")]
    BadStretchLimit(f64),
    /// A buffer or region was used with the wrong number of points.
    #[error("{what}: expected {expected} points, got {got}")]
    PointCount {
        /// What was being matched.
        what: &'static str,
        /// Points it was made for.
        expected: usize,
        /// Points given.
        got: usize,
    },
    /// A pipeline stage that failed (its index in the pipeline), and why:
    /// `stages[1]: radius of support must be ...`.
    #[error("stages[{index}]")]
    Stage {
        /// The stage's index.
        index: usize,
        /// Why it failed.
        #[source]
        source: Box<Error>,
    },
    /// A pipeline stage that does not exist.
    #[error("stage {index} does not exist: the pipeline has {count} stage(s)")]
    StageIndex {
        /// The index asked for.
        index: usize,
        /// How many stages there are.
        count: usize,
    },
    /// A binding used with a deformation fitted to other starts, kernel or
    /// radius (their fingerprints differ): its weights would be wrong.
    #[error(
        "{}: bind again, or solve from the system the binding came from",
        mismatch(*.bound_starts, *.bound_kernel, *.bound_radius, *.starts, *.kernel, *.radius)
    )]
    BindingMismatch {
        /// Starts the binding was made for.
        bound_starts: usize,
        /// Its kernel.
        bound_kernel: crate::Kernel,
        /// Its radius.
        bound_radius: f64,
        /// The deformation's starts.
        starts: usize,
        /// Its kernel.
        kernel: crate::Kernel,
        /// Its radius.
        radius: f64,
    },
    /// [`crate::System::solve_into`] given a deformation another system solved.
    #[error(
        "solve_into: the deformation was solved by another system (other starts, kernel or radius): solve into one this system made"
    )]
    SystemMismatch,
    /// A deformation gave a non-finite position.
    #[error(
        "deformation {stage} moved point {point} to a non-finite position: its control vectors ask for moves beyond floating-point range"
    )]
    NonFiniteResult {
        /// Which deformation.
        stage: usize,
        /// The first point.
        point: usize,
    },
    /// A sweep's steps chain; stages that add cannot hold one.
    #[error(
        "stage {stage} is a step of a sweep, whose steps act one after another: \"combine\": \"add\" cannot hold it; use \"chain\" (or no sweep)"
    )]
    SweepAdded {
        /// The stage.
        stage: usize,
    },
}

/// Why control vectors and options make no deformation: what was wrong and
/// where (control indices are the caller's).
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum FitError {
    /// The radius of support is zero, negative or not finite.
    #[error("radius of support must be a finite number > 0, got {0}")]
    BadRadius(f64),
    /// No control vectors were given.
    #[error("no control vectors: give at least one start and destination")]
    NoControls,
    /// Start and destination lists differ in length.
    #[error("{starts} start points but {targets} destinations")]
    LengthMismatch {
        /// Number of start points.
        starts: usize,
        /// Number of destinations.
        targets: usize,
    },
    /// A coordinate is NaN or infinite.
    #[error("control {index}: {what} has a coordinate that is not finite")]
    NotFinite {
        /// Index of the control vector.
        index: usize,
        /// `start` or `destination`.
        what: &'static str,
    },
    /// Two start points coincide, so the system is singular.
    #[error("controls {first} and {second} start at the same point; each start must be distinct")]
    DuplicateStart {
        /// The first of the two controls.
        first: usize,
        /// The second.
        second: usize,
    },
    /// Two starts are so close for this radius that the kernel cannot tell them apart.
    #[error(
        "controls {first} and {second} start {} apart, {} of the radius {}: too close for the kernel to tell apart (its values there differ by less than 1e-10); merge them, move one, or choose a smaller radius",
        number(*.distance), number(*.distance / *.radius), number(*.radius)
    )]
    StartsTooClose {
        /// The first of the two controls.
        first: usize,
        /// The second.
        second: usize,
        /// Their distance.
        distance: f64,
        /// The radius of support.
        radius: f64,
    },
    /// Two starts nearly on top of each other whose moves differ by more
    /// than their distance: no smooth map does that.
    #[error(
        "controls {first} and {second} start {} apart ({} % of R) but their moves differ by {}: no smooth map does that without overshooting far away; give them the same move, merge them or move one away",
        number(*distance), number(distance / radius * 100.0), number(*difference)
    )]
    ConflictingStarts {
        /// The first control.
        first: usize,
        /// The second.
        second: usize,
        /// Their distance.
        distance: f64,
        /// How much their displacements differ.
        difference: f64,
        /// The radius of support.
        radius: f64,
    },
    /// The starts span a subnormal extent, or lie beyond f32's range.
    #[error(
        "the starts span {extent:e} and reach {size:e} from the origin: outside the range csrbf fits in (32-bit meshes, extents above 1e-298); rescale the model"
    )]
    StartScale {
        /// Largest side of the starts' box.
        extent: f64,
        /// Largest coordinate.
        size: f64,
    },
    /// `linear` needs at least 4 starts.
    #[error(
        "the linear polynomial needs at least 4 start points, got {0}; use polynomial \"none\" for fewer"
    )]
    TooFewForLinear(usize),
    /// All start points lie on one plane (or line), so the linear part is undetermined.
    #[error(
        "all start points lie on one plane (or line), so a linear polynomial is not determined by them; use polynomial \"none\" or add a start off that plane"
    )]
    CoplanarStarts,
    /// The Cholesky factorisation met a pivot <= 0.
    #[error(
        "the system is not numerically positive definite: pivot of control {control} is not positive (starts too close together for this radius?)"
    )]
    NotPositiveDefinite {
        /// The control vector whose pivot failed, in the caller's numbering.
        control: usize,
    },
    /// Destinations were given for a different number of starts than the system has.
    #[error("the system has {expected} start points but {got} destinations were given")]
    TargetCount {
        /// What the system was built for.
        expected: usize,
        /// What was given.
        got: usize,
    },
    /// A sweep's step count is 0 or above [`MAX_STEPS`].
    #[error("a sweep takes 1 to {} steps, got {steps}", MAX_STEPS)]
    SweepSteps {
        /// The count asked for.
        steps: usize,
    },
    /// Even the most steps leave a step that may fold.
    #[error(
        "a sweep of {steps} steps still has a step whose gradient bound is {} (>= 1, so it may fold): the control vectors pull apart too sharply for R; use a larger R or fewer, farther controls",
        number(*bound)
    )]
    SweepTooStiff {
        /// Steps tried.
        steps: usize,
        /// The worst step's bound.
        bound: f64,
    },
    /// Two starts' paths meet, so no map can carry both.
    #[error(
        "controls {first} and {second} meet on their way, at phase {phase:.3}: a sweep carries every start along its path and two cannot be at one place; change one path"
    )]
    PathsMeet {
        /// The first control.
        first: usize,
        /// The second.
        second: usize,
        /// Where on the way (0 start, 1 destination).
        phase: f64,
    },
    /// The sparse solver failed for a reason other than a pivot.
    #[error("sparse solver failed: {0}")]
    Solver(String),
    /// The system would take more memory than the limit allows.
    #[error(
        "R = {} reaches about {neighbours:.0} of the {starts} starts, so the system would take about {} GiB, {:.1}x the limit of {} GiB: use a smaller R (R = {} fits), or lift the limit knowingly (FitOptions::memory_limit in Rust, allow_large=True in Python, --allow-large for csrbf fit and deform)",
        number(*radius), number(bytes / GIB), bytes / *limit as f64, number(*limit as f64 / GIB), number(*suggested_radius)
    )]
    TooLarge {
        /// Estimated bytes.
        bytes: f64,
        /// The limit.
        limit: u64,
        /// Mean starts within R of a start.
        neighbours: f64,
        /// Number of starts.
        starts: usize,
        /// The radius asked for.
        radius: f64,
        /// A radius that fits.
        suggested_radius: f64,
    },
}

/// A name that is not one of the choices (control files, command lines).
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum NameError {
    /// A kernel name that is not one of c0, c2, c4, c6.
    #[error("unknown kernel {0:?}: expected one of c0, c2, c4, c6")]
    UnknownKernel(String),
    /// A polynomial name that is not `none` or `linear`.
    #[error("unknown polynomial {0:?}: expected one of none, linear")]
    UnknownPolynomial(String),
    /// A solver name that is not auto, skyline or supernodal.
    #[error("unknown solver {0:?}: expected auto, skyline or supernodal")]
    UnknownSolver(String),
    /// An ordering name that is not auto, rcm, breadth-first or identity.
    #[error("unknown ordering {0:?}: expected auto, rcm, breadth-first or identity")]
    UnknownOrdering(String),
    /// A combine name that is not `chain` or `add`.
    #[error("unknown combine {0:?}: expected chain or add")]
    UnknownCombine(String),
}

/// Bytes in a GiB (memory limits are powers of two: the default is 4 GiB).
const GIB: f64 = (1u64 << 30) as f64;

/// Why a `.csrbf` file cannot be read.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum FormatError {
    /// Damaged, truncated, or of another version (the message says which).
    #[error("not a valid .csrbf file: {0}")]
    Damaged(String),
    /// A file of several deformations, or one with a region or phase, read
    /// as a single deformation.
    #[error(
        "not a single deformation over every point: {0}; read it as a pipeline (csrbf::format::decode)"
    )]
    NotSingle(String),
    /// Replayed on another mesh than the one its regions' vertex indices
    /// refer to ([`crate::format::MeshStamp`]).
    #[error(
        "its regions list vertices by index and {0}: on this mesh they would name other vertices; fit it again on this mesh (csrbf fit --mesh)"
    )]
    OtherMesh(String),
}

/// Why a region cannot be used.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum RegionError {
    /// A field with a value no region has (the message names the field).
    #[error("region: {0}")]
    Invalid(String),
    /// A region names a part the mesh does not have.
    #[error("region names part {0:?}, which the mesh does not have")]
    UnknownGroup(String),
    /// A connected region used where no mesh surface resolves it.
    #[error(
        "region: a connected region is measured along the mesh's faces from the deformation's starts or handle: it needs a mesh with faces, and can only limit a deformation (its \"region\")"
    )]
    NeedsSurface,
    /// A vertex index in a region is out of range.
    #[error("region vertex {index} is out of range for {count} points")]
    Index {
        /// The bad index.
        index: usize,
        /// The number of points.
        count: usize,
    },
}

/// The engine's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// The pipeline stage the error is about, when it names one.
    pub fn stage(&self) -> Option<usize> {
        match self {
            Error::Stage { index, .. } | Error::SweepAdded { stage: index } => Some(*index),
            _ => None,
        }
    }

    /// The error without the stage it names ([`Error::Stage`]'s source).
    pub fn without_stage(self) -> Error {
        match self {
            Error::Stage { source, .. } => *source,
            e => e,
        }
    }
}

/// The most steps a sweep takes before it gives up.
pub const MAX_STEPS: usize = 1024;

/// `Ok` when a buffer has the length its points need.
pub(crate) fn check_len(what: &'static str, expected: usize, got: usize) -> Result<()> {
    if expected == got {
        Ok(())
    } else {
        Err(Error::PointCount {
            what,
            expected,
            got,
        })
    }
}

/// Names pipeline stage `index` in an error that does not already.
pub(crate) fn at_stage(index: usize) -> impl FnOnce(Error) -> Error {
    move |e| match e {
        e @ (Error::Stage { .. } | Error::StageIndex { .. } | Error::SweepAdded { .. }) => e,
        e => Error::Stage {
            index,
            source: Box::new(e),
        },
    }
}

/// The one check of a phase: within [0, 1] (NaN is not), else
/// [`Error::BadPhase`].
pub fn check_phase(phase: f64) -> Result<()> {
    if (0.0..=1.0).contains(&phase) {
        Ok(())
    } else {
        Err(Error::BadPhase(phase))
    }
}

/// What differs between a binding and the deformation it was given, in
/// words: the radius, the kernel, the count of starts, or (all three the
/// same) the starts themselves.
fn mismatch(
    bound_starts: usize,
    bound_kernel: crate::Kernel,
    bound_radius: f64,
    starts: usize,
    kernel: crate::Kernel,
    radius: f64,
) -> String {
    let mut differ = Vec::new();
    if bound_radius.to_bits() != radius.to_bits() {
        differ.push(format!(
            "radius {} where the binding's is {}",
            number(radius),
            number(bound_radius)
        ));
    }
    if bound_kernel != kernel {
        differ.push(format!(
            "kernel {kernel} where the binding's is {bound_kernel}"
        ));
    }
    if bound_starts != starts {
        differ.push(format!(
            "{starts} starts where the binding's has {bound_starts}"
        ));
    }
    if differ.is_empty() {
        format!(
            "the binding was made for other starts than this deformation's (both have {starts} starts, kernel {kernel} and radius {}, but the starts are not the same points)",
            number(radius)
        )
    } else {
        format!(
            "the binding was made for another deformation: this one has {}",
            differ.join(", ")
        )
    }
}

/// A number as a person writes it: four significant digits, in plain
/// decimals from 0.001 to a million, in powers of ten beyond (2.294e-7):
/// what errors and warnings print (`csrbf::plain_number`, for front ends'
/// messages).
pub fn number(x: f64) -> String {
    let a = x.abs();
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    if (1e-3..1e6).contains(&a) {
        // Four significant digits, trailing zeros dropped.
        let decimals = (3 - a.log10().floor() as i32).max(0) as usize;
        let s = format!("{x:.decimals$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_owned()
        } else {
            s
        }
    } else {
        let s = format!("{x:.3e}");
        let (mantissa, exponent) = s.split_once('e').unwrap_or((&s, "0"));
        let mantissa = mantissa.trim_end_matches('0').trim_end_matches('.');
        format!("{mantissa}e{exponent}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Kernel;

    #[test]
    fn numbers_read_as_a_person_writes_them() {
        for (x, want) in [
            (2.2938347365839933, "2.294"),
            (1e6, "1e6"),
            (1_000_000.5, "1e6"),
            (999_999.0, "999999"),
            (0.5, "0.5"),
            (0.001, "0.001"),
            (0.000_999_9, "9.999e-4"),
            (2.2938347365839933e-6, "2.294e-6"),
            (-3.25, "-3.25"),
            (0.0, "0"),
            (f64::INFINITY, "inf"),
            (12.0, "12"),
        ] {
            assert_eq!(number(x), want, "{x}");
        }
    }

    /// A binding's refusal names what differs, and only that.
    #[test]
    fn a_binding_mismatch_names_what_differs() {
        let e = |starts, kernel, radius| {
            Error::BindingMismatch {
                bound_starts: 10,
                bound_kernel: Kernel::C2,
                bound_radius: 0.5,
                starts,
                kernel,
                radius,
            }
            .to_string()
        };
        let radius = e(10, Kernel::C2, 0.75);
        assert!(
            radius.contains("radius 0.75 where the binding's is 0.5"),
            "{radius}"
        );
        assert!(
            !radius.contains("kernel") && !radius.contains("starts where"),
            "{radius}"
        );
        let kernel = e(10, Kernel::C4, 0.5);
        assert!(
            kernel.contains("kernel c4 where the binding's is c2"),
            "{kernel}"
        );
        assert!(!kernel.contains("radius"), "{kernel}");
        let count = e(12, Kernel::C2, 0.5);
        assert!(
            count.contains("12 starts where the binding's has 10"),
            "{count}"
        );
        let all = e(12, Kernel::C0, 2.0);
        for part in ["radius 2", "kernel c0", "12 starts"] {
            assert!(all.contains(part), "{all}");
        }
        let points = e(10, Kernel::C2, 0.5);
        assert!(
            points.contains("the starts are not the same points"),
            "{points}"
        );
        for m in [radius, kernel, count, all, points] {
            assert!(
                m.ends_with("bind again, or solve from the system the binding came from"),
                "{m}"
            );
        }
    }

    #[test]
    fn starts_too_close_say_how_close_against_the_radius() {
        let m = FitError::StartsTooClose {
            first: 0,
            second: 1,
            distance: 2.2938347365839933,
            radius: 1e6,
        }
        .to_string();
        assert!(
            m.contains("start 2.294 apart, 2.294e-6 of the radius 1e6"),
            "{m}"
        );
        assert!(m.contains("smaller radius"), "{m}");
    }
}
