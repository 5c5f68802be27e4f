//! Clearance (distance to the mesh) with parry3d.
