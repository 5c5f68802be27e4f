//! Mesh operations of the paper: face splitting, shrink/expand, region of interest.
