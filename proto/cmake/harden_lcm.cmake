cmake_minimum_required(VERSION 3.22)
# Runs after lcm-gen on every generated header (cmake -P, with -DGEN_DIR=...).
# lcm-gen 1.3.1 sizes a variable-length array from the untrusted count field before it checks that the bytes
# are there (`this->a.resize(this->n)`), so a forged count allocates gigabytes or throws; and a string
# length of 0 or less makes `assign(p, len - 1)` throw. This inserts a bound before each: a count must be
# 0..remaining bytes and its allocation at most 8x the remaining bytes; a string length 1..remaining bytes. The
# script fails the build if a header still holds an unguarded resize (a new lcm-gen pattern).
file(GLOB_RECURSE headers "${GEN_DIR}/*.hpp")
foreach(h IN LISTS headers)
  file(READ "${h}" text)
  # The count must fit the remaining bytes, and the allocation it causes (count x in-memory element size)
  # must stay within 8x those bytes, so a forged count cannot make a small message allocate a lot (every
  # element's in-memory size is below 8x its smallest encoding: 1 byte per primitive, 5 per string).
  string(REGEX REPLACE "([ ]*)this->([A-Za-z0-9_]+)\\.resize\\(this->([A-Za-z0-9_]+)\\);"
         "\\1if(this->\\3 < 0 || static_cast<int64_t>(this->\\3) * static_cast<int64_t>(sizeof(decltype(this->\\2)::value_type)) > 8 * static_cast<int64_t>(maxlen - pos) + 64 || this->\\3 > maxlen - pos) return -1; /*rgbdmap-guard*/\n\\1this->\\2.resize(this->\\3);"
         text "${text}")
  string(REPLACE "if(__elem_len > maxlen - pos) return -1;"
         "if(__elem_len < 1 || __elem_len > maxlen - pos) return -1; /*rgbdmap-guard*/" text "${text}")
  string(REGEX REPLACE "if\\(__([A-Za-z0-9_]+)_len__ > maxlen - pos\\) return -1;"
         "if(__\\1_len__ < 1 || __\\1_len__ > maxlen - pos) return -1; /*rgbdmap-guard*/" text "${text}")
  string(REGEX MATCHALL "\\.resize\\(" resizes "${text}")
  string(REGEX MATCHALL "maxlen - pos\\) return -1" bounds "${text}")
  string(REGEX MATCHALL "rgbdmap-guard" guards "${text}")
  list(LENGTH resizes n_resize)
  list(LENGTH bounds n_bounds)
  list(LENGTH guards n_guards)
  if(NOT n_bounds EQUAL n_guards OR n_guards LESS n_resize)
    message(FATAL_ERROR "harden_lcm: ${h}: ${n_resize} resizes, ${n_bounds} length checks, ${n_guards} guards")
  endif()
  file(WRITE "${h}" "${text}")
endforeach()
