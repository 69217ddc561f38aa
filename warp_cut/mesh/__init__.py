"""Surface meshes: generators, checks and the geometry that lives on them."""
