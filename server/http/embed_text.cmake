# Writes a C++ source holding one text file as a byte array (run by cmake -P at build time).
#   cmake -DINPUT=api/openapi.yaml -DOUTPUT=openapi_data.cc -DSYMBOL=kOpenApiDocument -P embed_text.cmake
# Defines gearloop::<SYMBOL> (the bytes, NUL-terminated) and gearloop::<SYMBOL>Size.
file(READ "${INPUT}" hex HEX)
string(LENGTH "${hex}" hex_length)
math(EXPR size "${hex_length} / 2")
string(REGEX REPLACE "([0-9a-f][0-9a-f])" "0x\\1," bytes "${hex}")
string(REGEX REPLACE "((0x[0-9a-f][0-9a-f],){24})" "\\1\n" bytes "${bytes}")
file(WRITE "${OUTPUT}.tmp"
"// Generated from ${INPUT} by embed_text.cmake; do not edit.\n"
"#include <cstddef>\n\n"
"namespace gearloop {\n"
"extern const unsigned char ${SYMBOL}[];\n"
"extern const std::size_t ${SYMBOL}Size;\n"
"const unsigned char ${SYMBOL}[] = {\n${bytes}0x00};\n"
"const std::size_t ${SYMBOL}Size = ${size};\n"
"}  // namespace gearloop\n")
file(COPY_FILE "${OUTPUT}.tmp" "${OUTPUT}" ONLY_IF_DIFFERENT)
file(REMOVE "${OUTPUT}.tmp")
