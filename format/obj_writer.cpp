// obj_writer: not written yet.
