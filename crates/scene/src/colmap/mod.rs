//! COLMAP sparse models (text and binary) and dense depth maps.
