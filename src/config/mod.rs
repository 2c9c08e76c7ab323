//! PURE. Strict TOML configuration, validated into [`crate::robot::Robot`]s.
//! (Being written.)
