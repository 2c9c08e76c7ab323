//! PURE. Move request -> pulse tables. (Being written.)
