"""Drive data: readers (IO-VNBD, column-mapped CSV), pandera schema, GNSS quality, segments."""
