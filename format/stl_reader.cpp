// stl_reader: not written yet.
