#pragma once
// mrd-firmware ctl: the client of a running firmware's control socket (params_server.hpp).

namespace mrd::firmware {

// argv[0] is "ctl". Exit status: 0 ok, 1 no firmware at the socket (or it failed),
// 2 refused / bad input.
int RunCtl(int argc, char** argv);

}  // namespace mrd::firmware
