//! SANS-IO. MEWTOCOL-COM frames and codecs. (Being written.)
