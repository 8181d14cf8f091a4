// off_reader: not written yet.
