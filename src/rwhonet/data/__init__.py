"""Drive data: readers (IO-VNBD, column-mapped CSV), canonical columns, pandera schemas, segments."""
