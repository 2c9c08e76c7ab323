//! The `linterpd` subcommands. (Being written.)
