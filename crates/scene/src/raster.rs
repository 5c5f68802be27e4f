//! Raster types shared by forest, labelgen and planner: RGB images, label images, confidence images.
