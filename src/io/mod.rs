//! Readers and writers: CSV tables with units in the headers.
