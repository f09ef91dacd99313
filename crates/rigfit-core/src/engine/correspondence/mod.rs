//! Correspondence: soft weights between data points and model points with an outlier
//! class. [`softassign`](mod@softassign) is the two-sided strategy (Gold et al.; Cannavò's
//! posing), [`em`] the one-sided one (Dewaele et al. 2006, eq. 17) over the [`candidates`]
//! found in a grid; [`posterior`] holds what every one-sided E-step shares, the Gaussian
//! kernel and the normalisation against the outlier class (the surface tracker's E-step uses
//! it too).

pub mod candidates;
pub mod em;
pub mod posterior;
pub mod softassign;

#[cfg(test)]
mod test_clouds;

pub use candidates::{Candidates, candidate_radius};
pub use em::{EmStep, WeightedPoints, em_step, em_step_with};
pub use posterior::{DEWAELE_OUTLIER_CONSTANT, Evidence, GaussianKernel, exp_negative};
pub use softassign::{MatchMatrix, SoftassignParams, softassign};
