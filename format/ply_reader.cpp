// ply_reader: not written yet.
