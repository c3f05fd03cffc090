//! The workspace's integration tests as one test binary: each file beside this one is a module
//! of it. One binary links the workspace's heavy dependencies (OpenCV, candle) once instead of
//! once per file, which was most of the suite's build time; the runner still starts every test
//! in a process of its own. The two tests that install a counting global allocator stay
//! binaries of their own (tests/Cargo.toml), as an allocator is chosen per binary.

mod bag_import;
mod benchmark_report;
mod cli_help_doc;
mod cli_synthetic_kitti;
mod docs_paths;
mod drives_manifest;
mod edge_consistency;
mod edge_embedded_io;
mod edge_faults;
mod edge_logs;
mod edge_qemu;
mod edge_serial;
mod edge_sessions;
mod edge_soak;
mod edge_stream;
mod edge_tcp;
mod edge_unread_client;
mod embassy_qemu;
mod estimate_accuracy;
mod estimate_bad_input;
mod estimate_cli;
mod estimate_size_budget;
mod estimate_tracks_replay;
mod estimated_source;
mod estimator_profiles;
mod eth_ucy_real;
mod experiment_report;
mod ffi_c_example;
mod firmware_paths;
mod fleet_ray;
mod float_functions_match_firmware;
mod float_vs_int8;
mod frontend_bad_input;
mod frontend_real_kitti;
mod frontend_sim_e2e;
mod fuzz_corpus_regression;
mod image_sim_fixture;
mod interrupted_training;
mod kernels_qemu;
mod kitti_ekf_jitter;
mod prop_cli_and_layout;
mod prop_core_numerics;
mod prop_wire_and_blob;
mod quickstart;
mod recording;
mod signed_model_link;
mod size_budgets;
mod source_rules;
mod stack_overflow_qemu;
mod stream_csv_machine_readable;
mod train_cli;
