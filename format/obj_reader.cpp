// obj_reader: not written yet.
