//! PURE. The execution model. (Being written.)
