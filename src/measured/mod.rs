//! Measured reflectance: tables of f_r sampled from real materials, as opposed to the analytic
//! models of [`crate::brdf`].
//!
//! * [`merl`] — the MERL BRDF database's `.binary` files (Matusik et al. 2003): the strict
//!   reader, the writer of synthetic files made from any analytic model (the tests use only
//!   those: the real data is MERL's, not ours to ship), and the interpolated lookup at a pair
//!   of directions.
//!
//! Fitting the survey's models to a table is [`crate::fit`] (`brdfwave brdf fit`).

pub mod merl;
