//! Preston's integration tests, one module per subject, in one test crate: one link of the
//! library instead of one per file. Run one subject with `cargo test --release --test it api::`.

mod common;

mod api;
mod api_machine_plan;
mod api_metrology;
mod api_optimize;
mod api_program;
mod auth;
mod bad_input;
mod calibration;
mod curved_edge;
mod curved_plans;
mod curved_removal;
mod deploy;
mod edge_pressure;
mod harmonics;
mod invariant;
mod layers;
mod machine;
mod map_analysis;
mod map_predict;
mod map_program;
mod map_removal_function;
mod maps;
mod metrology;
mod motion;
mod openapi_drift;
mod ops;
mod optimize_constraints;
mod optimize_paper;
mod optimize_reference;
mod paper;
mod plan_program;
mod plausibility;
mod plots;
mod polar;
mod polar_reference;
mod problems;
mod recommend;
mod records;
mod removal_accuracy;
mod request_parsing;
mod sanity_table;
mod tcp;
mod workbench;
