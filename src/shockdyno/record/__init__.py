"""MCAP recordings: writer, reader, schemas, CSV import and export."""
