// mesh_reader: not written yet.
