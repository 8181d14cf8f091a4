// draco_writer: not written yet.
