//! The numerical methods the fits share: a bounded least-squares solver with its
//! forward-difference Jacobian and the uncertainties that follow from it, the least squares
//! of two columns (a sine and a cosine part), and a one-dimensional minimum search. Each is
//! tested here on problems with known answers.

pub(crate) mod decompose;
pub mod lookup;
pub mod lsq;
pub(crate) mod poly;
mod search;
pub(crate) mod two_columns;
pub mod units;

pub(crate) use search::golden_section;
