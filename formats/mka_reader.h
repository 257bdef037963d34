// formats/mka_reader.h: the Klingelnberg P-series curve file (KS.MK.FILE,
// ".mka") reader (METROLOGY.md §2, shared/formats/README.md).
//
//   MeasurementFile file;
//   FileError error;
//   if (!ReadMkaFile(content, &file, &error)) return Refuse(error);   //
//   "file:line 37: ..."
//   // file.traces: profile traces at z (from the datum face), helix traces at
//   d, in um
//
// The file: line 1 `HEADER KS.MK.FILE`; a `KEY value ! comment` preamble
// (UNDEFINED -2147483.648 marks a missing point); numbered header lines `
// <code> :<label....>: values`; traces in blocks
//   TOPOGRAFIE: Zahn-Nr.: 1 /Profil:2 rechts / 48 Werte  / z= 11.500 (profile
//   at z) TOPOGRAFIE: Zahn-Nr.: 1 /Flankenlinie:1 links / 48 Werte  / d=
//   143.000 (helix at d)
// or plain blocks (a `Profil:` / `Flankenlinie:` line, then `Zahn-Nr.: 1 rechts
// / 480 Werte` heads: profiles at mid face, helices at the measuring diameter
// of code 46), values 12 per line. Profile values lie at equal roll-length
// steps from code 41 to 44 (diameters, left and right value), helix values at
// equal axial steps from code 61 to 64. Twist (`Verschränkung:`) and pitch
// (`Teilung:`) sections are skipped up to the next trace block.
//
// Refused, with the file line: not text; first line not `HEADER KS.MK.FILE` (a
// `KS.MW.FILE` value file says so); a number that does not parse, NaN/inf, a
// decimal comma; a repeated header code; a trace head that does not match;
// fewer or more values than `n Werte`; n < 2; missing codes 41/44 (profiles) or
// 61/64 (helices), or a range the wrong way; a line not understood.
#ifndef GEARLOOP_FORMATS_MKA_READER_H_
#define GEARLOOP_FORMATS_MKA_READER_H_

#include <string_view>

#include "formats/measurement_file.h"

namespace gearloop {

bool ReadMkaFile(std::string_view content,
                 MeasurementFile* file,
                 FileError* error);

}  // namespace gearloop

#endif  // GEARLOOP_FORMATS_MKA_READER_H_
