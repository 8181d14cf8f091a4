// ply_writer: not written yet.
