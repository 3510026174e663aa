"""Readers and writers: the only place where tankcd touches files."""
