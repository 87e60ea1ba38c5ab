//! The solver's tests, one binary: a module per file beside this one (one link, not one
//! per file), and the helpers two of them share.

mod cradle_matrix_common;
mod progress_common;
mod stepwise_common;

mod cradle_matrix;
mod cradle_simulated;
mod diagnosis_effect_coverage;
mod diagnosis_positioning_real;
mod diagnosis_positioning_transient;
mod diagnosis_series_drift;
mod diagnosis_series_kernel;
mod diagnosis_series_positioning;
mod diagnosis_sessions;
mod diagnosis_thermal_coverage;
mod explained_model;
mod fits_simulated;
mod fits_sscanss2;
mod identification_truth;
mod misfit_gate;
mod noise_floor;
mod sensitivity_chain;
mod sensitivity_measures;
mod simulate_session;
mod standards_iso230_2;
mod standards_iso230_4;
mod stepwise_bias;
mod stepwise_truth;
mod tolerance_truth;
