//! The tracker's error: options out of range (see [`super::TwinOptions`])
//! or a time that is not finite. Messages name the options' fields.

/// Why a [`super::Tracker`] could not be built or advanced.
#[derive(Clone, Debug, PartialEq)]
pub enum TrackError {
    /// `edge` (the target edge length) is not a positive number.
    EdgeNotPositive(f64),
    /// `edge` is below the domain's largest side / 1000 (`min`): the
    /// mechanical mesh would need millions of triangles.
    EdgeTooSmall {
        /// The edge length asked for.
        edge: f64,
        /// The smallest one accepted.
        min: f64,
    },
    /// More than `max` geometric refinement passes.
    TooManyPasses {
        /// The passes asked for.
        passes: usize,
        /// The most accepted.
        max: usize,
    },
    /// A time that is not finite.
    Time(f64),
    /// Edge bounds with `e_min ≤ 0` or `e_max < 2 e_min` (a split would
    /// call for a collapse).
    EdgeBand {
        /// The lower bound.
        e_min: f64,
        /// The upper bound.
        e_max: f64,
    },
    /// Material constants outside `young > 0`, `−1 < poisson < 0.5`.
    Material {
        /// Young's modulus.
        young: f64,
        /// Poisson's ratio.
        poisson: f64,
    },
    /// A step with `dt` or `max_move` not positive, or `eps_e < 0`.
    Step {
        /// The time step.
        dt: f64,
        /// The energy tolerance.
        eps_e: f64,
        /// The largest vertex move per step.
        max_move: f64,
    },
    /// A sharpness angle `alpha_deg` that is not finite.
    Alpha(f64),
    /// The tracker's [`crate::cancel::Cancel`] token was cancelled (see
    /// "Cancelling" in [`super`]).
    Cancelled,
}

impl From<crate::cancel::Cancelled> for TrackError {
    fn from(_: crate::cancel::Cancelled) -> TrackError {
        TrackError::Cancelled
    }
}

impl std::fmt::Display for TrackError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            TrackError::EdgeNotPositive(e) => write!(f, "edge must be positive, got {e}"),
            TrackError::EdgeTooSmall { edge, min } => write!(
                f,
                "edge {edge} is below the domain's largest side / 1000 ({min}): the mechanical mesh would need millions of triangles"
            ),
            TrackError::TooManyPasses { passes, max } => write!(
                f,
                "passes {passes} is above {max} (each pass can double the geometric mesh)"
            ),
            TrackError::Time(t) => write!(f, "time must be finite, got {t}"),
            TrackError::EdgeBand { e_min, e_max } => write!(
                f,
                "need 0 < e_min and e_max ≥ 2·e_min (a split must not call for a collapse), got {e_min} and {e_max}"
            ),
            TrackError::Material { young, poisson } => {
                write!(f, "need E > 0 and −1 < ν < 0.5, got {young} and {poisson}")
            }
            TrackError::Step {
                dt,
                eps_e,
                max_move,
            } => write!(
                f,
                "dt, max_move must be positive, eps_e ≥ 0 (got {dt}, {max_move}, {eps_e})"
            ),
            TrackError::Alpha(a) => write!(f, "alpha must be finite, got {a}"),
            TrackError::Cancelled => f.write_str("cancelled"),
        }
    }
}

impl std::error::Error for TrackError {}
