# Writes a C++ source holding the dashboard files as byte arrays (run by cmake -P at build time).
#   cmake -DSOURCE_DIR=clients/web -DOUTPUT=web_assets_data.cc -DFILES="index.html|app.js" -P embed_assets.cmake
# Bytes, not string literals: no escaping rules to get wrong and no limit on literal length.
string(REPLACE "|" ";" files "${FILES}")
set(entries "")
set(arrays "")
set(index 0)
foreach(file IN LISTS files)
  file(READ "${SOURCE_DIR}/${file}" hex HEX)
  string(LENGTH "${hex}" hex_length)
  math(EXPR size "${hex_length} / 2")
  string(REGEX REPLACE "([0-9a-f][0-9a-f])" "0x\\1," bytes "${hex}")
  # Break the array into lines of 24 bytes for compilers and editors.
  string(REGEX REPLACE "((0x[0-9a-f][0-9a-f],){24})" "\\1\n" bytes "${bytes}")
  string(APPEND arrays "const unsigned char kAsset${index}[] = {\n${bytes}0x00};\n")
  string(APPEND entries "    {\"/static/${file}\", kAsset${index}, ${size}},\n")
  math(EXPR index "${index} + 1")
endforeach()
file(WRITE "${OUTPUT}.tmp"
"// Generated from clients/web by embed_assets.cmake; do not edit.\n"
"#include \"clients/web/web_assets_table.h\"\n\n"
"namespace gearloop {\nnamespace {\n${arrays}}  // namespace\n\n"
"const EmbeddedWebAsset kEmbeddedWebAssets[] = {\n${entries}    {nullptr, nullptr, 0}};\n\n"
"}  // namespace gearloop\n")
# Touch the output only when it changed, so an unchanged asset set does not relink the server.
file(COPY_FILE "${OUTPUT}.tmp" "${OUTPUT}" ONLY_IF_DIFFERENT)
file(REMOVE "${OUTPUT}.tmp")
