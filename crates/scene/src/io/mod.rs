//! Mesh file formats: PLY (ascii, binary little and big endian) and OBJ.
