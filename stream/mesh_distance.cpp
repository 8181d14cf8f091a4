// mesh_distance: not written yet.
