"""HDF5 channel files: the reader and writer, and the child-process probe that reads
a file's metadata first."""
