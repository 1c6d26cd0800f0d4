/* link_up IFNAME: sets a network interface up over rtnetlink (RTM_NEWLINK, IFF_UP), for the
 * virtual board's kernel, which has no INET: busybox `ip link set up` needs an AF_INET socket.
 * Exit 0 on success, 1 with the reason on stderr. */
#include <linux/if.h>
#include <linux/netlink.h>
#include <linux/rtnetlink.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

int main(int argc, char** argv) {
  if (argc != 2 || strlen(argv[1]) >= IFNAMSIZ) {
    fprintf(stderr, "usage: link_up IFNAME\n");
    return 1;
  }
  struct {
    struct nlmsghdr nh;
    struct ifinfomsg ifi;
    char attrs[64];
  } req;
  memset(&req, 0, sizeof req);
  const size_t name_len = strlen(argv[1]) + 1;
  struct rtattr* rta = (struct rtattr*)req.attrs;
  rta->rta_type = IFLA_IFNAME;
  rta->rta_len = (unsigned short)RTA_LENGTH(name_len);
  memcpy(RTA_DATA(rta), argv[1], name_len);
  req.nh.nlmsg_len = NLMSG_LENGTH(sizeof req.ifi) + RTA_ALIGN(rta->rta_len);
  req.nh.nlmsg_type = RTM_NEWLINK;
  req.nh.nlmsg_flags = NLM_F_REQUEST | NLM_F_ACK;
  req.nh.nlmsg_seq = 1;
  req.ifi.ifi_family = AF_UNSPEC;
  req.ifi.ifi_flags = IFF_UP;
  req.ifi.ifi_change = IFF_UP;
  const int fd = socket(AF_NETLINK, SOCK_RAW | SOCK_CLOEXEC, NETLINK_ROUTE);
  if (fd < 0 || send(fd, &req, req.nh.nlmsg_len, 0) < 0) {
    perror("link_up: netlink");
    return 1;
  }
  char buf[512];
  const ssize_t n = recv(fd, buf, sizeof buf, 0);
  const struct nlmsghdr* ack = (const struct nlmsghdr*)buf;
  if (n < (ssize_t)NLMSG_LENGTH(sizeof(struct nlmsgerr)) || ack->nlmsg_type != NLMSG_ERROR) {
    fprintf(stderr, "link_up: no acknowledgement\n");
    return 1;
  }
  const int err = ((const struct nlmsgerr*)NLMSG_DATA(ack))->error;
  if (err != 0) {
    fprintf(stderr, "link_up: %s: %s\n", argv[1], strerror(-err));
    return 1;
  }
  close(fd);
  return 0;
}
