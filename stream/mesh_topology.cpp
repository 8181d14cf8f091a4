// mesh_topology: not written yet.
