// The Cyclone DDS configuration the daemon starts from; a user's configuration
// (the daemon's option, else CYCLONEDDS_URI) comes after it and overrides it.
#pragma once

namespace rsd::dds {

// Cyclone receives into 1 MiB ring buffers by default, one per receiving thread, whose
// pages become resident as messages pass: with discovery's little traffic the RSS crept
// up for many minutes (the soak), then see-sawed each time a ring was replaced; 256 KiB
// rings fill in the first minutes and keep RSS flat after. Messages are still received
// in 128 KiB chunks (Fast DDS sends up to 64 KiB). A user's configuration overrides.
//
// One receive thread for all sockets (MultipleReceiveThreads false): Cyclone stops
// a thread of its own per socket by sending that socket a packet through the
// network, and once the host's address is gone (a renumbering, a lease lost, an
// adapter unplugged) that send fails and deleting the domain waits for ever
// (measured: 0.10.2, the participant made anew after the address was removed
// never came; the main thread sat in dds_delete joining "recvMC"). The single
// thread waits on a waitset that a pipe wakes. Discovery traffic is light.
// The participant announces itself every second (Cyclone: every 8 s): a peer sends its
// endpoints once it has heard it, and a refresh on a lossy link waited for the next.
// Its lease is realdds' own 3 s (Cyclone: 10 s): a server that cannot hear the daemon
// drops it as soon as the daemon drops the server, instead of keeping for 10 s a
// participant it believes it told its endpoints (measured across cuts on a lossy
// link: the camera came back sooner, never later). Missing samples are asked for
// again every 200 ms (Cyclone: 3 s) while the writer does not answer: a realdds
// server otherwise repairs its lost endpoint announcements on its own 3 s heartbeats.
inline constexpr const char* kCycloneDefaults =
    "<Sizing><ReceiveBufferSize>256KiB</ReceiveBufferSize></Sizing>"
    "<Internal><MultipleReceiveThreads>false</MultipleReceiveThreads>"
    "<AutoReschedNackDelay>200 ms</AutoReschedNackDelay></Internal>"
    "<Discovery><SPDPInterval>1 s</SPDPInterval><LeaseDuration>3 s</LeaseDuration></Discovery>";

}  // namespace rsd::dds
