//! Ray casting over a mesh with a CWBVH (obvhs).
