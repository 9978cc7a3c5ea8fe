// The UDP receiving options that record and bridge share.
#include "app/cli_help.h"
#include "app/commands.h"
#include "tracking/udp_receiver.h"

namespace gs::app {

void AddUdpReceiveOptions(CLI::App* cmd, tracking::UdpOptions* udp) {
  cmd->add_option("--port", udp->port, "UDP port the tracker sends to (0: any free port, printed)")
      ->type_name("PORT")
      ->required()
      ->check(IntInRange(0, 65535, "a UDP port"));
  cmd->add_option("--multicast", udp->multicast_group, "join this multicast group (e.g. 224.0.1.0)")
      ->type_name("GROUP");
  cmd->add_option("--allow", udp->allowed_senders, "accept datagrams only from these IPv4 addresses")
      ->type_name("ADDRESS");
  cmd->add_option("--controller", udp->controller,
                  "send the DTrack firewall nudge to this Controller address (UDP 50107)")
      ->type_name("ADDRESS");
}

}  // namespace gs::app
