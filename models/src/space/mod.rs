//! Space design: ray-traced propagation through the scene (obvhs BVHs, one ray-query API for all
//! sensors). To be written.
