//! dynotraj-host: KITTI I/O, trajectory sources, evaluation and the `dynotraj` command.
